/* The device link's frames, the device's side: see lwrl_link.h. */
#include <string.h>

#include "lwrl_link.h"

#define PAYLOAD LWRL_LINK_HEADER_SIZE /* where a frame's payload starts */

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

static uint64_t read_le(const uint8_t *p, int bytes)
{
    uint64_t value = 0;
    int i;
    for (i = bytes - 1; i >= 0; i--)
        value = value << 8 | p[i];
    return value;
}

static double read_double(const uint8_t *p)
{
    uint64_t bits = read_le(p, LWRL_LINK_REAL_SIZE);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static void write_le(uint8_t *p, uint64_t value, int bytes)
{
    int i;
    for (i = 0; i < bytes; i++)
        p[i] = (uint8_t)(value >> (8 * i));
}

static void write_double(uint8_t *p, double value)
{
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    write_le(p, bits, LWRL_LINK_REAL_SIZE);
}

/* Whether `length` bytes of payload hold `fixed` bytes and then a whole number of reals,
 * at most `most` of them. */
static int fixed_and_reals(uint8_t length, int fixed, int most)
{
    return length >= fixed && (length - fixed) % LWRL_LINK_REAL_SIZE == 0
           && (length - fixed) / LWRL_LINK_REAL_SIZE <= most;
}

/* Whether a payload of `length` bytes can be a frame of `kind` that this reader takes. */
static int fits(uint8_t kind, uint8_t length)
{
    if (kind == LWRL_LINK_ACTION)
        return length == LWRL_LINK_ACTION_INDEX_SIZE || length == LWRL_LINK_ACTION_VALUE_SIZE;
    if (kind == LWRL_LINK_REQUEST)
        return length == LWRL_LINK_REQUEST_SIZE;
    if (kind == LWRL_LINK_HELLO || kind == LWRL_LINK_IDENTITY)
        return length >= LWRL_LINK_IDENTITY_SIZE
               && length <= LWRL_LINK_IDENTITY_SIZE + LWRL_LINK_MAX_TASK;
    if (kind == LWRL_LINK_WEIGHTS)
        return length > LWRL_LINK_WEIGHTS_SIZE
               && fixed_and_reals(length, LWRL_LINK_WEIGHTS_SIZE, LWRL_LINK_WEIGHTS_PER_FRAME);
    return kind == LWRL_LINK_OBSERVATION
           && fixed_and_reals(length, LWRL_LINK_OBSERVATION_SIZE, LWRL_LINK_MAX_DIM);
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

/* The length of the frame begun at b, its header read. */
static uint16_t frame_length(const uint8_t *b)
{
    return (uint16_t)LWRL_LINK_FRAME(b[LWRL_LINK_HEADER_PAYLOAD_LENGTH]);
}

/* 1: buffer[0 .. used) holds a whole valid frame; 0: it may become one; -1: it cannot. */
static int check(const lwrl_link_reader *reader)
{
    const uint8_t *b = reader->buffer;
    uint16_t end;
    if (reader->used < LWRL_LINK_HEADER_SIZE)
        return 0;
    if (b[LWRL_LINK_HEADER_VERSION] != LWRL_LINK_VERSION
        || !fits(b[LWRL_LINK_HEADER_KIND], b[LWRL_LINK_HEADER_PAYLOAD_LENGTH]))
        return -1;
    end = frame_length(b);
    if (reader->used < end)
        return 0;
    return lwrl_link_crc16(b + 1, (uint16_t)(end - 1 - LWRL_LINK_CRC_SIZE))
                   == (uint16_t)read_le(b + end - LWRL_LINK_CRC_SIZE, LWRL_LINK_CRC_SIZE)
           ? 1 : -1;
}

static void read_identity(const uint8_t *p, uint8_t length, lwrl_link_identity *out)
{
    int name = length - LWRL_LINK_IDENTITY_SIZE;
    out->observations = p[LWRL_LINK_IDENTITY_OBSERVATIONS];
    out->action_kind = p[LWRL_LINK_IDENTITY_ACTION_KIND];
    out->actions = (uint16_t)read_le(p + LWRL_LINK_IDENTITY_ACTIONS, 2);
    out->arithmetic = p[LWRL_LINK_IDENTITY_ARITHMETIC];
    out->build = read_le(p + LWRL_LINK_IDENTITY_BUILD, 8);
    memcpy(out->task, p + LWRL_LINK_IDENTITY_SIZE, (size_t)name);
    out->task[name] = '\0';
}

int lwrl_link_feed(lwrl_link_reader *reader, uint8_t byte, lwrl_link_message *out)
{
    int state, j;
    if (reader->used == 0 && byte != LWRL_LINK_MAGIC) {
        reader->skipped++;
        return 0;
    }
    reader->buffer[reader->used++] = byte;
    while (reader->used > 0 && (state = check(reader)) != 0) {
        const uint8_t *b = reader->buffer;
        const uint8_t *p = b + PAYLOAD;
        uint8_t kind = b[LWRL_LINK_HEADER_KIND], length = b[LWRL_LINK_HEADER_PAYLOAD_LENGTH];
        uint16_t end = frame_length(b);
        int taken = 0; /* the kind of the frame taken */
        if (state < 0) {
            resync(reader);
            continue;
        }
        out->step = (uint32_t)read_le(b + LWRL_LINK_HEADER_STEP, 4);
        if (kind == LWRL_LINK_OBSERVATION) {
            out->flags = p[LWRL_LINK_OBSERVATION_FLAGS];
            out->dim = (uint8_t)((length - LWRL_LINK_OBSERVATION_SIZE) / LWRL_LINK_REAL_SIZE);
            out->reward = read_double(p + LWRL_LINK_OBSERVATION_REWARD);
            for (j = 0; j < out->dim; j++)
                out->observation[j] = read_double(p + LWRL_LINK_OBSERVATION_SIZE
                                                  + LWRL_LINK_REAL_SIZE * j);
            taken = kind;
        } else if (kind == LWRL_LINK_REQUEST) {
            out->offset = (uint32_t)read_le(p, LWRL_LINK_REQUEST_SIZE);
            taken = kind;
        } else if (kind == LWRL_LINK_HELLO) {
            read_identity(p, length, &out->identity);
            taken = kind;
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
 * at out + PAYLOAD, and its CRC; returns the frame's length. */
static int seal(uint32_t step, uint8_t kind, int length, uint8_t *out)
{
    out[LWRL_LINK_HEADER_MAGIC] = LWRL_LINK_MAGIC;
    out[LWRL_LINK_HEADER_VERSION] = LWRL_LINK_VERSION;
    out[LWRL_LINK_HEADER_KIND] = kind;
    out[LWRL_LINK_HEADER_PAYLOAD_LENGTH] = (uint8_t)length;
    write_le(out + LWRL_LINK_HEADER_STEP, step, 4);
    write_le(out + PAYLOAD + length, lwrl_link_crc16(out + 1, (uint16_t)(PAYLOAD - 1 + length)),
             LWRL_LINK_CRC_SIZE);
    return LWRL_LINK_FRAME(length);
}

int lwrl_link_action_index(uint32_t step, int32_t index, uint8_t *out)
{
    out[PAYLOAD + LWRL_LINK_ACTION_INDEX_KIND] = LWRL_LINK_DISCRETE;
    write_le(out + PAYLOAD + LWRL_LINK_ACTION_INDEX_ACTION, (uint32_t)index, 4);
    return seal(step, LWRL_LINK_ACTION, LWRL_LINK_ACTION_INDEX_SIZE, out);
}

int lwrl_link_action_value(uint32_t step, double value, uint8_t *out)
{
    out[PAYLOAD + LWRL_LINK_ACTION_VALUE_KIND] = LWRL_LINK_CONTINUOUS;
    write_double(out + PAYLOAD + LWRL_LINK_ACTION_VALUE_ACTION, value);
    return seal(step, LWRL_LINK_ACTION, LWRL_LINK_ACTION_VALUE_SIZE, out);
}

int lwrl_link_weights(uint32_t step, uint32_t total, uint32_t offset, int diverged,
                      const double *values, int count, uint8_t *out)
{
    uint8_t *p = out + PAYLOAD;
    int j;
    write_le(p + LWRL_LINK_WEIGHTS_TOTAL, total, 4);
    write_le(p + LWRL_LINK_WEIGHTS_OFFSET, offset, 4);
    p[LWRL_LINK_WEIGHTS_DIVERGED] = diverged ? 1 : 0;
    for (j = 0; j < count; j++)
        write_double(p + LWRL_LINK_WEIGHTS_SIZE + LWRL_LINK_REAL_SIZE * j, values[j]);
    return seal(step, LWRL_LINK_WEIGHTS, LWRL_LINK_WEIGHTS_SIZE + LWRL_LINK_REAL_SIZE * count, out);
}

int lwrl_link_identity_frame(uint32_t step, const lwrl_link_identity *identity, uint8_t *out)
{
    uint8_t *p = out + PAYLOAD;
    size_t name = strlen(identity->task);
    p[LWRL_LINK_IDENTITY_OBSERVATIONS] = identity->observations;
    p[LWRL_LINK_IDENTITY_ACTION_KIND] = identity->action_kind;
    write_le(p + LWRL_LINK_IDENTITY_ACTIONS, identity->actions, 2);
    p[LWRL_LINK_IDENTITY_ARITHMETIC] = identity->arithmetic;
    write_le(p + LWRL_LINK_IDENTITY_BUILD, identity->build, 8);
    memcpy(p + LWRL_LINK_IDENTITY_SIZE, identity->task, name);
    return seal(step, LWRL_LINK_IDENTITY, LWRL_LINK_IDENTITY_SIZE + (int)name, out);
}

int lwrl_link_same_identity(const lwrl_link_identity *a, const lwrl_link_identity *b)
{
    return a->observations == b->observations && a->action_kind == b->action_kind
           && a->actions == b->actions && a->arithmetic == b->arithmetic && a->build == b->build
           && strcmp(a->task, b->task) == 0;
}
