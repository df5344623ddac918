/* Number formatting shared by both builds: digits written into a buffer, then lwrl_print. */
#include "device_io.h"

void lwrl_print_uint(uint64_t value)
{
    char text[21];
    int at = 20;
    text[at] = '\0';
    do {
        text[--at] = (char)('0' + (int)(value % 10u));
        value /= 10u;
    } while (value != 0u);
    lwrl_print(text + at);
}

void lwrl_print_hex(uint64_t value)
{
    static const char digits[] = "0123456789abcdef";
    char text[17];
    int at;
    for (at = 15; at >= 0; at--) {
        text[at] = digits[value & 15u];
        value >>= 4;
    }
    text[16] = '\0';
    lwrl_print(text);
}
