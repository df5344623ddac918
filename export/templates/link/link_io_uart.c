/* link_io.h on the emulated Cortex-M4 (QEMU's mps2-an386): the stream is UART0, the CMSDK
 * APB UART at 0x40004000, which QEMU connects to its first serial port (-serial stdio: its
 * standard input and output). Polled, no interrupts: a byte in waits in the data register
 * until read, a byte out waits until the transmitter is free. The start-up is
 * io_semihosting.c's, which calls lwrl_device_main. */
#include "link_io.h"

#define UART0_DATA (*(volatile uint32_t *)0x40004000u)
#define UART0_STATE (*(volatile uint32_t *)0x40004004u) /* bit 0: TX full; bit 1: RX full */
#define UART0_CTRL (*(volatile uint32_t *)0x40004008u) /* bit 0: TX on; bit 1: RX on */
#define UART0_BAUDDIV (*(volatile uint32_t *)0x40004010u)

int lwrl_link_getc(void)
{
    while (!(UART0_STATE & 2u)) {
    }
    return (int)(UART0_DATA & 0xFFu);
}

void lwrl_link_write(const uint8_t *bytes, int length)
{
    int i;
    for (i = 0; i < length; i++) {
        while (UART0_STATE & 1u) {
        }
        UART0_DATA = bytes[i];
    }
}

int lwrl_device_main(void)
{
    UART0_BAUDDIV = 16u; /* the smallest divider the UART takes */
    UART0_CTRL = 3u;
    return lwrl_link_main();
}
