/* A device program that learns over the link: the C learner (lwrl_learner.h) answers each
 * observation frame with its action (lwrl_link.h), the stream's bytes coming and going
 * through link_io.h (standard input and output on the host, link_io_host.c; the UART on
 * the emulated Cortex-M4, link_io_uart.c). A hello gets the program's identity (the task
 * and learner build of link_identity.h, the learner's dimensions and arithmetic); a hello
 * that is not that identity leaves the program refusing: it acts on no observation and
 * sends no weights until a hello that is. A frame of the step it answered last (a
 * duplicate) gets that answer again, and teaches the learner nothing twice. A request
 * gets the learned weights from its offset, as doubles. An observation that finds no
 * episode under way (the device has just started, or restarted mid-episode) begins one:
 * the learner never learns from a transition it did not see. */
#include <string.h>

#include "link_identity.h"
#include "link_io.h"
#include "lwrl_learner.h"
#include "lwrl_link.h"

int lwrl_link_main(void)
{
    static lwrl_link_reader reader;
    static lwrl_link_identity own;
    static uint8_t answer[LWRL_LINK_ACTION_FRAME];
    static uint8_t piece[LWRL_LINK_WEIGHTS_FRAME];
    static uint8_t identity[LWRL_LINK_IDENTITY_FRAME];
    static double values[LWRL_LINK_WEIGHTS_PER_FRAME];
    static lwrl_link_message frame;
    lwrl_real observation[LWRL_STATE_DIM];
    int c, j, kind, count, action, length = 0, answered = 0, under_way = 0, refused = 0;
    uint32_t last_step = 0;

    own.observations = LWRL_STATE_DIM;
    own.action_kind = LWRL_LINK_DISCRETE;
    own.actions = LWRL_NUM_ACTIONS;
    own.arithmetic = sizeof(lwrl_real) == sizeof(float) ? LWRL_LINK_FLOAT : LWRL_LINK_DOUBLE;
    own.build = LWRL_LINK_BUILD;
    strcpy(own.task, LWRL_LINK_TASK);
    lwrl_reset(LWRL_SEED);
    lwrl_link_reader_init(&reader);
    while ((c = lwrl_link_getc()) >= 0) {
        kind = lwrl_link_feed(&reader, (uint8_t)c, &frame);
        if (kind == LWRL_LINK_HELLO) {
            refused = !lwrl_link_same_identity(&frame.identity, &own);
            lwrl_link_write(identity, lwrl_link_identity_frame(frame.step, &own, identity));
        }
        if (refused)
            continue;
        if (kind == LWRL_LINK_REQUEST && frame.offset < LWRL_NUM_WEIGHTS) {
            count = LWRL_NUM_WEIGHTS - (int)frame.offset;
            if (count > LWRL_LINK_WEIGHTS_PER_FRAME)
                count = LWRL_LINK_WEIGHTS_PER_FRAME;
            for (j = 0; j < count; j++)
                values[j] = (double)lwrl_weights()[frame.offset + (uint32_t)j];
            lwrl_link_write(piece, lwrl_link_weights(frame.step, LWRL_NUM_WEIGHTS, frame.offset,
                                                     lwrl_diverged(), values, count, piece));
        }
        if (kind != LWRL_LINK_OBSERVATION || frame.dim != LWRL_STATE_DIM)
            continue;
        if (!(answered && frame.step == last_step)) {
            for (j = 0; j < LWRL_STATE_DIM; j++)
                observation[j] = (lwrl_real)frame.observation[j];
            if ((frame.flags & LWRL_LINK_START) || !under_way)
                action = lwrl_begin(observation);
            else
                action = lwrl_learn(observation, (lwrl_real)frame.reward,
                                    (frame.flags & LWRL_LINK_TERMINAL) != 0);
            under_way = !(frame.flags & (LWRL_LINK_TERMINAL | LWRL_LINK_TRUNCATED));
            length = lwrl_link_action_index(frame.step, action, answer);
            last_step = frame.step;
            answered = 1;
        }
        lwrl_link_write(answer, length);
    }
    return 0;
}
