/*
 * Instruction counter for `cargo xtask bench`: counts the guest instructions executed from
 * the first instruction of a "begin" marker function to the first instruction of an "end"
 * marker function, once per region, in execution order.
 *
 *   qemu-system-arm ... -plugin libinsn_count.so,begin=0x...,end=0x...,out=FILE
 *
 * Writes one line per region to FILE: "region <n> <instructions>". The count includes the
 * begin marker's own instructions and the call of the end marker; the benchmark measures an
 * empty region as well and subtracts it. Every executed instruction is seen through an
 * execution callback (not per translation block), so partial blocks and re-translations do
 * not change the count; with -icount shift=0 the run is deterministic.
 *
 * Optional trace=FILE2 writes "<region> <pc>" for every instruction counted, so the count of
 * a region can be split by function (`cargo xtask bench --by-function` does, with the DWARF).
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qemu_plugin_api.h"

__attribute__((visibility("default"))) int qemu_plugin_version = INSN_COUNT_API_VERSION;

static uint64_t begin_addr = UINT64_MAX;
static uint64_t end_addr = UINT64_MAX;
static FILE *out;
static FILE *trace;
static int active;
static uint64_t count;
static unsigned regions;

static void on_insn(unsigned int vcpu, void *udata)
{
    uint64_t pc = (uint64_t)(uintptr_t)udata;
    (void)vcpu;
    if (pc == begin_addr) {
        active = 1;
        count = 1;
        if (trace != NULL) {
            fprintf(trace, "%u %" PRIx64 "\n", regions, pc);
        }
        return;
    }
    if (!active) {
        return;
    }
    if (pc == end_addr) {
        active = 0;
        fprintf(out, "region %u %" PRIu64 "\n", regions++, count);
        fflush(out);
        return;
    }
    count++;
    if (trace != NULL) {
        fprintf(trace, "%u %" PRIx64 "\n", regions, pc);
    }
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    (void)id;
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        qemu_plugin_register_vcpu_insn_exec_cb(insn, on_insn, QEMU_PLUGIN_CB_NO_REGS,
                                               (void *)(uintptr_t)pc);
    }
}

static void on_qemu_exit(qemu_plugin_id_t id, void *udata)
{
    (void)id;
    (void)udata;
    if (active) {
        fprintf(out, "unfinished %u %" PRIu64 "\n", regions, count);
    }
    fclose(out);
    if (trace != NULL) {
        fclose(trace);
    }
}

static int parse_addr(const char *arg, const char *key, uint64_t *dst)
{
    size_t k = strlen(key);
    if (strncmp(arg, key, k) != 0 || arg[k] != '=') {
        return 0;
    }
    char *end = NULL;
    *dst = strtoull(arg + k + 1, &end, 0);
    return end != NULL && *end == '\0' && end != arg + k + 1;
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t *info,
                                                               int argc, char **argv)
{
    const char *path = NULL;
    const char *trace_path = NULL;
    if (info->version.cur < INSN_COUNT_API_VERSION ||
        info->version.min > INSN_COUNT_API_VERSION) {
        fprintf(stderr, "insn_count: QEMU plugin API %d..%d, built for %d\n", info->version.min,
                info->version.cur, INSN_COUNT_API_VERSION);
        return -1;
    }
    for (int i = 0; i < argc; i++) {
        if (parse_addr(argv[i], "begin", &begin_addr) || parse_addr(argv[i], "end", &end_addr)) {
            continue;
        }
        if (strncmp(argv[i], "out=", 4) == 0) {
            path = argv[i] + 4;
            continue;
        }
        if (strncmp(argv[i], "trace=", 6) == 0) {
            trace_path = argv[i] + 6;
            continue;
        }
        fprintf(stderr, "insn_count: unknown argument '%s'\n", argv[i]);
        return -1;
    }
    if (begin_addr == UINT64_MAX || end_addr == UINT64_MAX || path == NULL) {
        fprintf(stderr, "insn_count: needs begin=ADDR,end=ADDR,out=FILE\n");
        return -1;
    }
    out = fopen(path, "w");
    if (out == NULL) {
        fprintf(stderr, "insn_count: cannot write %s\n", path);
        return -1;
    }
    if (trace_path != NULL) {
        trace = fopen(trace_path, "w");
        if (trace == NULL) {
            fprintf(stderr, "insn_count: cannot write %s\n", trace_path);
            return -1;
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, on_qemu_exit, NULL);
    return 0;
}
