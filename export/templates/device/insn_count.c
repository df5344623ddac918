/* A QEMU TCG plugin that counts the guest's executed instructions and writes the total at
 * exit ("instructions N", through QEMU's log: -d plugin -D FILE). Each translated block adds
 * its instruction count to the total when it runs (an inline add, as QEMU's own libinsn
 * example does). With the argument skip=START:END (hexadecimal addresses, as
 * `-plugin FILE,skip=0x100:0x110`), blocks that start in [START, END) are not counted: a
 * polling loop's wait, which is no work of the program. Built against QEMU's plugin API version 1 (QEMU 4.2 to 8.x); the few
 * declarations it needs are below, so no QEMU headers are needed to build it. */
#include <inttypes.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
typedef struct {
    const char *target_name;
    struct {
        int min, cur;
    } version;
    /* more fields follow; unused here */
} qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

static uint64_t instructions;
static uint64_t skip_start, skip_end; /* blocks starting in [skip_start, skip_end) not counted */

static void translated(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    uint64_t start = qemu_plugin_tb_vaddr(tb);
    (void)id;
    if (start >= skip_start && start < skip_end)
        return;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &instructions,
                                             qemu_plugin_tb_n_insns(tb));
}

static void finished(qemu_plugin_id_t id, void *userdata)
{
    char line[64];
    (void)id;
    (void)userdata;
    snprintf(line, sizeof line, "instructions %" PRIu64 "\n", instructions);
    qemu_plugin_outs(line);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t *info, int argc,
                                                               char **argv)
{
    int i;
    char *rest;
    (void)info;
    for (i = 0; i < argc; i++) {
        if (strncmp(argv[i], "skip=", 5) != 0)
            return -1;
        skip_start = strtoull(argv[i] + 5, &rest, 16);
        if (*rest != ':')
            return -1;
        skip_end = strtoull(rest + 1, NULL, 16);
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, translated);
    qemu_plugin_register_atexit_cb(id, finished, NULL);
    return 0;
}
