/* Output and exit of a device program: semihosting on the emulated Cortex-M4
 * (io_semihosting.c), the C library on the host (io_host.c). The programs use nothing
 * else of the machine, so the host build and the device build run the same code. */
#ifndef LWRL_DEVICE_IO_H
#define LWRL_DEVICE_IO_H

#include <stdint.h>

/* Write a NUL-terminated string. */
void lwrl_print(const char *text);

/* Write an unsigned integer in decimal. */
void lwrl_print_uint(uint64_t value);

/* Write an unsigned integer as 16 hexadecimal digits. */
void lwrl_print_hex(uint64_t value);

/* End the program: status 0 for success, anything else for failure. */
void lwrl_exit(int status);

#endif /* LWRL_DEVICE_IO_H */
