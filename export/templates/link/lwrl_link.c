/* The device link's frames, the device's side: see lwrl_link.h. */
#include <string.h>

#include "lwrl_link.h"

uint16_t lwrl_link_crc16(const uint8_t *data, uint16_t length)
{
    uint16_t crc = 0xFFFFu;
    uint16_t i;
    int bit;
    for (i = 0; i < length; i++) {
        crc ^= (uint16_t)(data[i] << 8);
        for (bit = 0; bit < 8; bit++)
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
    return crc;
}

void lwrl_link_reader_init(lwrl_link_reader *reader)
{
    reader->used = 0;
    reader->skipped = 0;
}

static uint32_t read_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static double read_double(const uint8_t *p)
{
    uint64_t bits = 0;
    double value;
    int i;
    for (i = 7; i >= 0; i--)
        bits = bits << 8 | p[i];
    memcpy(&value, &bits, sizeof value);
    return value;
}

static void write_u32(uint8_t *p, uint32_t value)
{
    int i;
    for (i = 0; i < 4; i++)
        p[i] = (uint8_t)(value >> (8 * i));
}

static void write_double(uint8_t *p, double value)
{
    uint64_t bits;
    int i;
    memcpy(&bits, &value, sizeof bits);
    for (i = 0; i < 8; i++)
        p[i] = (uint8_t)(bits >> (8 * i));
}

/* Whether a payload of `length` bytes can be a frame of `kind` that this reader takes. */
static int fits(uint8_t kind, uint8_t length)
{
    if (kind == LWRL_LINK_ACTION)
        return length == 5 || length == 9;
    if (kind == LWRL_LINK_REQUEST)
        return length == 4;
    if (length < 9 || (length - 9) % 8 != 0)
        return 0;
    if (kind == LWRL_LINK_WEIGHTS)
        return length > 9 && (length - 9) / 8 <= LWRL_LINK_WEIGHTS_PER_FRAME;
    return kind == LWRL_LINK_OBSERVATION && (length - 9) / 8 <= LWRL_LINK_MAX_DIM;
}

/* Drop the frame begun at buffer[0] and what follows it up to the next MAGIC. */
static void resync(lwrl_link_reader *reader)
{
    uint16_t next = 1;
    while (next < reader->used && reader->buffer[next] != LWRL_LINK_MAGIC)
        next++;
    reader->skipped += next;
    memmove(reader->buffer, reader->buffer + next, (size_t)(reader->used - next));
    reader->used = (uint16_t)(reader->used - next);
}

/* 1: buffer[0 .. used) holds a whole valid frame; 0: it may become one; -1: it cannot. */
static int check(const lwrl_link_reader *reader)
{
    const uint8_t *b = reader->buffer;
    uint16_t end;
    if (reader->used < LWRL_LINK_HEADER)
        return 0;
    if (b[1] != LWRL_LINK_VERSION || !fits(b[2], b[3]))
        return -1;
    end = (uint16_t)(LWRL_LINK_HEADER + b[3] + 2);
    if (reader->used < end)
        return 0;
    return lwrl_link_crc16(b + 1, (uint16_t)(end - 3)) == (uint16_t)(b[end - 2] | b[end - 1] << 8)
           ? 1 : -1;
}

int lwrl_link_feed(lwrl_link_reader *reader, uint8_t byte, lwrl_link_observation *out)
{
    int state, j;
    if (reader->used == 0 && byte != LWRL_LINK_MAGIC) {
        reader->skipped++;
        return 0;
    }
    reader->buffer[reader->used++] = byte;
    while (reader->used > 0 && (state = check(reader)) != 0) {
        const uint8_t *b = reader->buffer;
        uint16_t end = (uint16_t)(LWRL_LINK_HEADER + b[3] + 2);
        int taken = 0; /* the kind of the frame taken */
        if (state < 0) {
            resync(reader);
            continue;
        }
        if (b[2] == LWRL_LINK_OBSERVATION) {
            out->step = read_u32(b + 4);
            out->flags = b[8];
            out->dim = (uint8_t)((b[3] - 9) / 8);
            out->reward = read_double(b + 9);
            for (j = 0; j < out->dim; j++)
                out->observation[j] = read_double(b + 17 + 8 * j);
            taken = LWRL_LINK_OBSERVATION;
        } else if (b[2] == LWRL_LINK_REQUEST) {
            out->step = read_u32(b + 4);
            out->offset = read_u32(b + 8);
            taken = LWRL_LINK_REQUEST;
        }
        /* the frame is taken; bytes after it (read while resynchronising) stay */
        memmove(reader->buffer, reader->buffer + end, (size_t)(reader->used - end));
        reader->used = (uint16_t)(reader->used - end);
        if (taken)
            return taken;
    }
    return 0;
}

/* The header of a frame of `kind` and `length` bytes of payload, whose payload is already
 * at out + 8, and its CRC; returns the frame's length. */
static int seal(uint32_t step, uint8_t kind, int length, uint8_t *out)
{
    uint16_t crc;
    out[0] = LWRL_LINK_MAGIC;
    out[1] = LWRL_LINK_VERSION;
    out[2] = kind;
    out[3] = (uint8_t)length;
    write_u32(out + 4, step);
    crc = lwrl_link_crc16(out + 1, (uint16_t)(7 + length));
    out[8 + length] = (uint8_t)(crc & 0xFFu);
    out[9 + length] = (uint8_t)(crc >> 8);
    return 10 + length;
}

int lwrl_link_action_index(uint32_t step, int32_t index, uint8_t *out)
{
    out[8] = 0;
    write_u32(out + 9, (uint32_t)index);
    return seal(step, LWRL_LINK_ACTION, 5, out);
}

int lwrl_link_action_value(uint32_t step, double value, uint8_t *out)
{
    out[8] = 1;
    write_double(out + 9, value);
    return seal(step, LWRL_LINK_ACTION, 9, out);
}

int lwrl_link_weights(uint32_t step, uint32_t total, uint32_t offset, int diverged,
                      const double *values, int count, uint8_t *out)
{
    int j;
    write_u32(out + 8, total);
    write_u32(out + 12, offset);
    out[16] = diverged ? 1 : 0;
    for (j = 0; j < count; j++)
        write_double(out + 17 + 8 * j, values[j]);
    return seal(step, LWRL_LINK_WEIGHTS, 9 + 8 * count, out);
}
