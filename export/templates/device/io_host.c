/* The host's device_io.h: standard output and exit(). */
#include <stdio.h>
#include <stdlib.h>

#include "device_io.h"

void lwrl_print(const char *text)
{
    fputs(text, stdout);
}

void lwrl_exit(int status)
{
    fflush(stdout);
    exit(status);
}

int lwrl_device_main(void);

int main(void)
{
    lwrl_exit(lwrl_device_main());
    return 0;
}
