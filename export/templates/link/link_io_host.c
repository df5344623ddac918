/* link_io.h on the host: the stream is standard input and output. */
#include <stdio.h>

#include "link_io.h"

int lwrl_link_getc(void)
{
    int c = getchar();
    return c == EOF ? -1 : c;
}

void lwrl_link_write(const uint8_t *bytes, int length)
{
    fwrite(bytes, 1, (size_t)length, stdout);
    fflush(stdout);
}

int main(void)
{
    return lwrl_link_main();
}
