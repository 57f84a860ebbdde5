"""A minimal stand-in for LinuxCNC's HAL and RTAPI C API, to compile and run a generated component without LinuxCNC.

The declarations copy the names, types and signatures of LinuxCNC's public headers (LinuxCNC/linuxcnc at commit
5c41560, ``src/hal/hal.h``: ``hal_float_t`` = ``volatile real_t`` (double), ``hal_bit_t`` = ``volatile bool``,
``hal_pdir_t`` ``HAL_IN = 1 << 4``, ``HAL_OUT = 1 << 5``, ``HAL_NAME_LEN`` 55, ``hal_init``, ``hal_exit``,
``hal_malloc``, ``hal_ready``, ``hal_pin_bit_newf``, ``hal_pin_float_newf``, ``hal_export_functf``;
``src/rtapi/rtapi.h``: ``msg_level_t``, ``rtapi_print_msg``, ``rtapi_snprintf``, ``MODULE_*``, ``RTAPI_MP_INT``;
``src/rtapi/rtapi_app.h``: ``rtapi_app_main``, ``rtapi_app_exit``). :data:`STUB_C` implements them as a test needs:
pins are doubles and bools in a table, looked up by name; the exported function is kept and called by the driver,
which reads one sample of inputs per line and prints the outputs.
"""

from __future__ import annotations

RTAPI_H = r"""
#ifndef RTAPI_H
#define RTAPI_H
typedef enum { RTAPI_MSG_NONE = 0, RTAPI_MSG_ERR, RTAPI_MSG_WARN, RTAPI_MSG_INFO, RTAPI_MSG_DBG,
               RTAPI_MSG_ALL } msg_level_t;
extern void rtapi_print_msg(msg_level_t level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
extern int rtapi_snprintf(char *buf, unsigned long int size, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
#define MODULE_AUTHOR(s) extern int rtapi_module_info_unused
#define MODULE_DESCRIPTION(s) extern int rtapi_module_info_unused
#define MODULE_LICENSE(s) extern int rtapi_module_info_unused
#endif
"""

RTAPI_APP_H = r"""
#ifndef RTAPI_APP_H
#define RTAPI_APP_H
#define RTAPI_MP_INT(var, descr) extern int rtapi_module_info_unused
extern int rtapi_app_main(void);
extern void rtapi_app_exit(void);
#endif
"""

HAL_H = r"""
#ifndef HAL_H
#define HAL_H
#include <stdbool.h>
#define HAL_NAME_LEN 55
typedef double real_t;
typedef volatile bool hal_bit_t;
typedef volatile real_t hal_float_t;
typedef enum { HAL_DIR_UNSPECIFIED = -1, HAL_IN = (1 << 4), HAL_OUT = (1 << 5), HAL_IO = (HAL_IN | HAL_OUT),
               HAL_RO = (1 << 6), HAL_WO = (1 << 7), HAL_RW = (HAL_RO | HAL_WO) } hal_pdir_t;
typedef hal_pdir_t hal_pin_dir_t;
extern int hal_init(const char *name);
extern int hal_exit(int comp_id);
extern void *hal_malloc(long int size);
extern int hal_ready(int comp_id);
extern int hal_pin_bit_newf(hal_pin_dir_t dir, hal_bit_t **data_ptr_addr, int comp_id, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
extern int hal_pin_float_newf(hal_pin_dir_t dir, hal_float_t **data_ptr_addr, int comp_id, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
extern int hal_export_functf(void (*funct)(void *, long), void *arg, int uses_fp, int reentrant, int comp_id,
                             const char *fmt, ...) __attribute__((format(printf, 6, 7)));
#endif
"""

STUB_C = r"""
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "rtapi.h"
#include "rtapi_app.h"
#include "hal.h"

#define MAX_PINS 64
static char pin_names[MAX_PINS][HAL_NAME_LEN + 1];
static hal_float_t *float_pins[MAX_PINS];
static hal_bit_t *bit_pins[MAX_PINS];
static int n_pins;
static void (*funct)(void *, long);
static void *funct_arg;
static char funct_name[HAL_NAME_LEN + 1];
static int ready, exited;

void rtapi_print_msg(msg_level_t level, const char *fmt, ...) {
    va_list ap; (void)level; va_start(ap, fmt); vfprintf(stderr, fmt, ap); va_end(ap);
}
int rtapi_snprintf(char *buf, unsigned long int size, const char *fmt, ...) {
    va_list ap; int n; va_start(ap, fmt); n = vsnprintf(buf, size, fmt, ap); va_end(ap); return n;
}
int hal_init(const char *name) { (void)name; return 7; }
int hal_exit(int comp_id) { (void)comp_id; exited = 1; return 0; }
void *hal_malloc(long int size) { return calloc(1, (size_t)size); }
int hal_ready(int comp_id) { (void)comp_id; ready = 1; return 0; }
static int new_pin(const char *fmt, va_list ap) {
    if (n_pins >= MAX_PINS) return -1;
    vsnprintf(pin_names[n_pins], HAL_NAME_LEN + 1, fmt, ap);
    return n_pins++;
}
int hal_pin_bit_newf(hal_pin_dir_t dir, hal_bit_t **p, int comp_id, const char *fmt, ...) {
    va_list ap; int i; (void)dir; (void)comp_id;
    va_start(ap, fmt); i = new_pin(fmt, ap); va_end(ap);
    if (i < 0) return -1;
    bit_pins[i] = calloc(1, sizeof(hal_bit_t)); *p = bit_pins[i]; return 0;
}
int hal_pin_float_newf(hal_pin_dir_t dir, hal_float_t **p, int comp_id, const char *fmt, ...) {
    va_list ap; int i; (void)dir; (void)comp_id;
    va_start(ap, fmt); i = new_pin(fmt, ap); va_end(ap);
    if (i < 0) return -1;
    float_pins[i] = calloc(1, sizeof(hal_float_t)); *p = float_pins[i]; return 0;
}
int hal_export_functf(void (*f)(void *, long), void *arg, int uses_fp, int reentrant, int comp_id,
                      const char *fmt, ...) {
    va_list ap; (void)uses_fp; (void)reentrant; (void)comp_id;
    va_start(ap, fmt); vsnprintf(funct_name, sizeof(funct_name), fmt, ap); va_end(ap);
    funct = f; funct_arg = arg; return 0;
}
static int find(const char *name) {
    for (int i = 0; i < n_pins; ++i) if (strcmp(pin_names[i], name) == 0) return i;
    fprintf(stderr, "no pin %s\n", name); exit(3);
}

/* argv: period_ns, then the input pins, then "--", then the output pins; stdin: one line of inputs per sample,
   first the enable bit; stdout: one line of outputs per sample, then the rate-fault bit */
int main(int argc, char **argv) {
    int ins[16], outs[16], n_in = 0, n_out = 0, k = 2, en, fault;
    long period = atol(argv[1]);
    if (rtapi_app_main() != 0 || !ready || funct == 0) { fprintf(stderr, "rtapi_app_main failed\n"); return 2; }
    printf("function %s\n", funct_name);
    for (; k < argc && strcmp(argv[k], "--") != 0; ++k) ins[n_in++] = find(argv[k]);
    for (++k; k < argc; ++k) outs[n_out++] = find(argv[k]);
    en = find("ft_test.0.enable");
    fault = find("ft_test.0.rate-fault");
    for (;;) {
        double e;
        if (scanf("%lf", &e) != 1) break;
        *bit_pins[en] = e != 0.0;
        for (int i = 0; i < n_in; ++i) { double v; if (scanf("%lf", &v) != 1) return 4; *float_pins[ins[i]] = v; }
        funct(funct_arg, period);
        for (int i = 0; i < n_out; ++i) printf("%.17g ", (double)*float_pins[outs[i]]);
        printf("%d\n", (int)*bit_pins[fault]);
    }
    rtapi_app_exit();
    return exited ? 0 : 5;
}
"""


def write_stub(folder) -> None:
    """Write ``rtapi.h``, ``rtapi_app.h``, ``hal.h`` and ``hal_stub.c`` into ``folder`` (a ``pathlib.Path``)."""
    for name, text in (("rtapi.h", RTAPI_H), ("rtapi_app.h", RTAPI_APP_H), ("hal.h", HAL_H),
                       ("hal_stub.c", STUB_C)):
        (folder / name).write_text(text)
