/* The emulated Cortex-M4's device_io.h and start-up: ARM semihosting (the debugger's
 * `bkpt 0xab` calls, which QEMU answers with -semihosting-config enable=on), the vector
 * table, and a reset handler that turns on the FPU, lays out .data and .bss and runs the
 * program. No C library start-up code and no stdio. */
#include <stdint.h>

#include "device_io.h"

#define SYS_WRITE0 0x04
#define SYS_EXIT 0x18
#define ADP_STOPPED_APPLICATION_EXIT 0x20026 /* exit status 0 */
#define ADP_STOPPED_RUN_TIME_ERROR 0x20023   /* any other: QEMU exits with status 1 */
#define CPACR (*(volatile uint32_t *)0xE000ED88u)

extern uint32_t _data_load, _data_start, _data_end, _bss_start, _bss_end, _stack_top;
int lwrl_device_main(void);

static int semihost(int operation, const void *argument)
{
    register int r0 __asm__("r0") = operation;
    register const void *r1 __asm__("r1") = argument;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void lwrl_print(const char *text)
{
    semihost(SYS_WRITE0, text);
}

void lwrl_exit(int status)
{
    semihost(SYS_EXIT, (const void *)(uintptr_t)(status == 0 ? ADP_STOPPED_APPLICATION_EXIT
                                                              : ADP_STOPPED_RUN_TIME_ERROR));
    for (;;) {
    }
}

void lwrl_reset_handler(void)
{
    uint32_t *from = &_data_load, *to;
    CPACR |= 0xFu << 20; /* full access to the FPU's coprocessors 10 and 11 */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    for (to = &_data_start; to < &_data_end;)
        *to++ = *from++;
    for (to = &_bss_start; to < &_bss_end;)
        *to++ = 0u;
    lwrl_exit(lwrl_device_main());
}

static void fault_handler(void)
{
    lwrl_print("fault\n");
    lwrl_exit(3);
}

/* The Cortex-M4's vector table: the initial stack pointer, then the handlers of reset and
 * of the 14 system exceptions (NMI, hard fault, ...). */
__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top, lwrl_reset_handler, fault_handler, fault_handler,
    fault_handler, fault_handler, fault_handler, 0, 0, 0, 0, fault_handler, fault_handler, 0,
    fault_handler, fault_handler,
};
