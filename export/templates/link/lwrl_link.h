/* The device link's frames, the device's side (C99, static memory only): what
 * lwrl.export.frames is on the host, byte for byte. docs/guide/device-link.md gives the
 * layout: MAGIC, VERSION, kind, payload length, step (uint32), payload, CRC-16/CCITT-FALSE
 * over everything but MAGIC and the CRC; numbers little-endian, reals IEEE 754 doubles. */
#ifndef LWRL_LINK_H
#define LWRL_LINK_H

#include <stdint.h>

#define LWRL_LINK_MAGIC 0xA5u
#define LWRL_LINK_VERSION 1u
#define LWRL_LINK_OBSERVATION 1u /* host to device */
#define LWRL_LINK_ACTION 2u /* device to host */
#define LWRL_LINK_REQUEST 3u /* host to device: the weights from an offset */
#define LWRL_LINK_WEIGHTS 4u /* device to host */
#define LWRL_LINK_WEIGHTS_PER_FRAME 30
#define LWRL_LINK_START 1u /* an observation's flags */
#define LWRL_LINK_TERMINAL 2u
#define LWRL_LINK_TRUNCATED 4u
#ifndef LWRL_LINK_MAX_DIM
#define LWRL_LINK_MAX_DIM 8 /* observed variables a reader takes at most */
#endif
#define LWRL_LINK_HEADER 8
#define LWRL_LINK_MAX_FRAME (LWRL_LINK_HEADER + 9 + 8 * LWRL_LINK_MAX_DIM + 2)
#define LWRL_LINK_ACTION_FRAME 19 /* bytes of the longest action frame */
#define LWRL_LINK_WEIGHTS_FRAME (LWRL_LINK_HEADER + 9 + 8 * LWRL_LINK_WEIGHTS_PER_FRAME + 2)

typedef struct { /* an observation, or a request (its offset) */
    uint32_t step;
    uint32_t offset; /* a REQUEST's: the first weight wanted */
    uint8_t flags; /* LWRL_LINK_START, _TERMINAL, _TRUNCATED */
    uint8_t dim; /* observed variables */
    double reward;
    double observation[LWRL_LINK_MAX_DIM];
} lwrl_link_observation;

typedef struct {
    uint8_t buffer[LWRL_LINK_MAX_FRAME];
    uint16_t used; /* bytes of a frame begun */
    uint32_t skipped; /* bytes skipped so far: noise, refused frames */
} lwrl_link_reader;

/* CRC-16/CCITT-FALSE of `length` bytes (check value 0x29B1 for "123456789"). */
uint16_t lwrl_link_crc16(const uint8_t *data, uint16_t length);

void lwrl_link_reader_init(lwrl_link_reader *reader);

/* Take one byte of the stream. Returns LWRL_LINK_OBSERVATION or LWRL_LINK_REQUEST when it
 * completes a frame of that kind, written to *out; 0 otherwise (a frame begun, a byte or a
 * refused frame skipped and counted, or a valid frame of another kind passed over). */
int lwrl_link_feed(lwrl_link_reader *reader, uint8_t byte, lwrl_link_observation *out);

/* An action frame answering step `step` into out[0 .. LWRL_LINK_ACTION_FRAME - 1]: a
 * discrete action's index or a continuous action; returns the frame's length. */
int lwrl_link_action_index(uint32_t step, int32_t index, uint8_t *out);
int lwrl_link_action_value(uint32_t step, double value, uint8_t *out);

/* A weights frame answering the request of step `step` into out[0 ..
 * LWRL_LINK_WEIGHTS_FRAME - 1]: `count` (1 .. LWRL_LINK_WEIGHTS_PER_FRAME) of the learner's
 * `total` weights from `offset`, and its diverged flag; returns the frame's length. */
int lwrl_link_weights(uint32_t step, uint32_t total, uint32_t offset, int diverged,
                      const double *values, int count, uint8_t *out);

#endif /* LWRL_LINK_H */
