/* The bytes of the device link: where a device program reads and writes them. */
#ifndef LWRL_LINK_IO_H
#define LWRL_LINK_IO_H

#include <stdint.h>

/* The next byte of the stream (waiting for it), or -1 once the stream has ended. */
int lwrl_link_getc(void);

/* Send `length` bytes, whole, before returning. */
void lwrl_link_write(const uint8_t *bytes, int length);

/* The program: reads frames and answers them until the stream ends; its exit status. */
int lwrl_link_main(void);

#endif /* LWRL_LINK_IO_H */
