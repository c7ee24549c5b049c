/* Minimal QEMU TCG plugin. Build with -DQEMU_PLUGIN_API=1 for QEMU 7.x/8.x
 * (Debian bookworm 7.2) or -DQEMU_PLUGIN_API=2 for QEMU >= 9 (bookworm-backports
 * 10.0), where the v1 inline ops were replaced by per-vCPU scoreboards.
 * Counts executed guest instructions: total; optionally those whose PC is in
 * [lo, hi) (one function's own body, callees excluded); and the instructions
 * from each execution of address start= to the next execution of stop=
 * (callees included), summed over all such windows.
 * With profile=FILE, also writes "pc count" (hex, decimal) for every executed
 * instruction address, for per-function and per-stage breakdowns.
 * With wprofile=FILE, writes "pc count taken" for every address executed
 * inside the start/stop windows: executions, and how many of them left
 * the instruction to anywhere but the next address (taken branches), for
 * the cycle model (scripts/qemu/cycles.py).
 * Usage: -plugin ./libinsncount.so[,lo=0x..,hi=0x..][,start=0x..,stop=0x..][,out=file][,profile=file][,wprofile=file]
 * Own declarations of the handful of API entry points used (C ABI). */
#include <stdint.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EXPORT __attribute__((visibility("default")))
typedef uint64_t qemu_plugin_id_t;
typedef struct {
    const char *target_name;
    struct { int min; int cur; } version;
    bool system_emulation;
    union { struct { int smp_vcpus; int max_vcpus; } system; };
} qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
#ifndef QEMU_PLUGIN_API
#define QEMU_PLUGIN_API 1
#endif
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
#if QEMU_PLUGIN_API >= 2
struct qemu_plugin_scoreboard;
typedef struct { struct qemu_plugin_scoreboard *score; size_t offset; } qemu_plugin_u64;
struct qemu_plugin_scoreboard *qemu_plugin_scoreboard_new(size_t element_size);
void *qemu_plugin_scoreboard_find(struct qemu_plugin_scoreboard *, unsigned int vcpu_index);
uint64_t qemu_plugin_u64_sum(qemu_plugin_u64 entry);
void qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu(struct qemu_plugin_insn *, enum qemu_plugin_op, qemu_plugin_u64, uint64_t);
static struct qemu_plugin_scoreboard *sb;   /* per vCPU: {total, in_range} */
#define TOTAL() (*(uint64_t *)qemu_plugin_scoreboard_find(sb, vcpu))
#define INLINE_ADD(insn, off) qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu( \
        insn, QEMU_PLUGIN_INLINE_ADD_U64, (qemu_plugin_u64){ sb, (off) }, 1)
#else
#define TOTAL() total
#define INLINE_ADD(insn, off) qemu_plugin_register_vcpu_insn_exec_inline( \
        insn, QEMU_PLUGIN_INLINE_ADD_U64, (off) ? (void *)&in_range : (void *)&total, 1)
#endif
typedef void (*tb_trans_cb_t)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*udata_cb_t)(qemu_plugin_id_t, void *);
typedef void (*vcpu_udata_cb_t)(unsigned int, void *);
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *, vcpu_udata_cb_t, enum qemu_plugin_cb_flags, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, tb_trans_cb_t);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *, size_t);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, udata_cb_t, void *);

EXPORT int qemu_plugin_version = QEMU_PLUGIN_API;

static uint64_t total, in_range, lo, hi, start_pc, stop_pc, snap, window, nwin;
static int in_win;

static void on_start(unsigned int vcpu, void *u) { snap = TOTAL(); in_win = 1; }
static void on_stop(unsigned int vcpu, void *u) { if (in_win) { window += TOTAL() - snap; nwin++; in_win = 0; } }
static const char *outpath;

/* Per-PC counters, open addressing on pc + 1 (0 marks a free slot). */
#define PROF_SLOTS (1u << 18)
static struct { uint64_t key, count; } *prof;
static const char *profpath;
static uint64_t *prof_counter(uint64_t pc)
{
    uint64_t i = (pc * 0x9E3779B97F4A7C15ull) >> 46;   /* 18 bits */
    while (prof[i].key && prof[i].key != pc + 1)
        i = (i + 1) & (PROF_SLOTS - 1);
    prof[i].key = pc + 1;
    return &prof[i].count;
}
static void prof_exec(unsigned int vcpu, void *counter) { ++*(uint64_t *)counter; }

/* Window profile: per instruction its address, size, executions in a window
 * and taken exits; the previous instruction executed is the one whose exit
 * the next execution's address reveals. Single vCPU (the boards here). */
#define WPROF_MAX (1u << 18)
static struct wprof { uint64_t pc, size, count, taken; } *wprof;
static uint64_t wprof_used;
static struct wprof *wprof_last;
static const char *wprofpath;
static void wprof_exec(unsigned int vcpu, void *u)
{
    struct wprof *w = u;
    if (wprof_last && wprof_last->pc + wprof_last->size != w->pc)
        wprof_last->taken++;
    wprof_last = NULL;
    if (!in_win)
        return;
    w->count++;
    wprof_last = w;
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        /* marker callbacks first, then count: window = insns from start marker
         * (inclusive) up to stop marker (exclusive) */
        if (start_pc && pc == start_pc)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_start, QEMU_PLUGIN_CB_NO_REGS, NULL);
        if (stop_pc && pc == stop_pc)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_stop, QEMU_PLUGIN_CB_NO_REGS, NULL);
        INLINE_ADD(insn, 0);
        if (prof) {
#if QEMU_PLUGIN_API >= 2
            qemu_plugin_register_vcpu_insn_exec_cb(insn, prof_exec, QEMU_PLUGIN_CB_NO_REGS, prof_counter(pc));
#else
            (void)prof_exec;
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, prof_counter(pc), 1);
#endif
        }
        if (hi > lo && pc >= lo && pc < hi)
            INLINE_ADD(insn, sizeof(uint64_t));
        /* after the markers' callbacks: the start marker's first instruction
         * counts, the stop marker's does not (as the window's count) */
        if (wprof && wprof_used < WPROF_MAX) {
            struct wprof *w = &wprof[wprof_used++];
            w->pc = pc;
            w->size = qemu_plugin_insn_size(insn);
            qemu_plugin_register_vcpu_insn_exec_cb(insn, wprof_exec, QEMU_PLUGIN_CB_NO_REGS, w);
        }
    }
}

static void at_exit(qemu_plugin_id_t id, void *p)
{
#if QEMU_PLUGIN_API >= 2
    total = qemu_plugin_u64_sum((qemu_plugin_u64){ sb, 0 });
    in_range = qemu_plugin_u64_sum((qemu_plugin_u64){ sb, sizeof(uint64_t) });
#endif
    FILE *f = outpath ? fopen(outpath, "w") : stderr;
    if (!f) f = stderr;
    fprintf(f, "insncount: total=%llu range=%llu window=%llu windows=%llu\n",
            (unsigned long long)total, (unsigned long long)in_range,
            (unsigned long long)window, (unsigned long long)nwin);
    if (f != stderr) fclose(f);
    if (prof && (f = fopen(profpath, "w"))) {
        for (uint64_t i = 0; i < PROF_SLOTS; i++)
            if (prof[i].count)
                fprintf(f, "%llx %llu\n", (unsigned long long)(prof[i].key - 1),
                        (unsigned long long)prof[i].count);
        fclose(f);
    }
    /* An address translated more than once (TBs retranslated) has several
     * entries: the reader sums them. */
    if (wprof && (f = fopen(wprofpath, "w"))) {
        for (uint64_t i = 0; i < wprof_used; i++)
            if (wprof[i].count)
                fprintf(f, "%llx %llu %llu\n", (unsigned long long)wprof[i].pc,
                        (unsigned long long)wprof[i].count, (unsigned long long)wprof[i].taken);
        fclose(f);
    }
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    for (int i = 0; i < argc; i++) {
        if (!strncmp(argv[i], "lo=", 3)) lo = strtoull(argv[i] + 3, NULL, 0);
        else if (!strncmp(argv[i], "hi=", 3)) hi = strtoull(argv[i] + 3, NULL, 0);
        else if (!strncmp(argv[i], "out=", 4)) outpath = argv[i] + 4;
        else if (!strncmp(argv[i], "profile=", 8)) {
            profpath = argv[i] + 8;
            prof = calloc(PROF_SLOTS, sizeof *prof);
            if (!prof) return -1;
        }
        else if (!strncmp(argv[i], "wprofile=", 9)) {
            wprofpath = argv[i] + 9;
            wprof = calloc(WPROF_MAX, sizeof *wprof);
            if (!wprof) return -1;
        }
        else if (!strncmp(argv[i], "start=", 6)) start_pc = strtoull(argv[i] + 6, NULL, 0) & ~1ULL;
        else if (!strncmp(argv[i], "stop=", 5)) stop_pc = strtoull(argv[i] + 5, NULL, 0) & ~1ULL;
        else { fprintf(stderr, "insncount: bad arg %s\n", argv[i]); return -1; }
    }
#if QEMU_PLUGIN_API >= 2
    sb = qemu_plugin_scoreboard_new(2 * sizeof(uint64_t));
#endif
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
