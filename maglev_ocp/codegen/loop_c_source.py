"""C text of the compiled closed loop ``run_loop`` (one scenario in one call).

``run_loop(loop_t *s)`` steps a controller's compiled step and the plant's
code-generated step Function ``s->n`` times, both called through CasADi's
calling convention by function pointer, and logs every step into
preallocated arrays. It does, in the same order and with the same floating
point operations, what :meth:`maglev_ocp.plant.Plant.step` does around its
step Function (limiter, delay buffer, noise from pre-drawn sequences,
disturbance forces, stops, encoder) and what
:class:`maglev_ocp.loop.ClosedLoop` does around the controller (stop on an
error or on non-finite currents). Compiled with ``-ffp-contract=off`` and
without fast-math, so each operation rounds as in Python.

:data:`LOOP_FIELDS` is the struct's layout (every field 8 bytes), mirrored by
the ctypes structure of :mod:`maglev_ocp.codegen.loop_c`.
"""

from __future__ import annotations

#: ``loop_t`` fields: (name, C type); ``i`` = long long, ``d`` = double, ``p`` = pointer.
LOOP_FIELDS: tuple[tuple[str, str], ...] = (
    # sizes and flags
    ("n", "i"),
    ("nxa", "i"),
    ("np", "i"),
    ("delay", "i"),
    ("log_size", "i"),
    ("ref_n", "i"),
    ("meas_n", "i"),
    ("n_cables", "i"),
    ("state_in", "i"),
    ("state_out", "i"),
    ("meas_in", "i"),
    ("ref_in", "i"),
    ("u_off", "i"),
    ("lim_on", "i"),
    ("proc_on", "i"),
    ("cur_on", "i"),
    ("meas_on", "i"),
    ("lock_g", "i"),
    ("lock_d", "i"),
    ("stops_on", "i"),
    ("has_force", "i"),
    ("has_payload", "i"),
    ("timing", "i"),
    ("i_axis", "d"),
    ("i_amp", "d"),
    ("q", "d"),
    # plant call
    ("plant_f", "p"),
    ("p_arg", "p"),
    ("p_res", "p"),
    ("p_iw", "p"),
    ("p_w", "p"),
    ("xa", "p"),
    ("xa_out", "p"),
    ("u_in", "p"),
    ("pbuf", "p"),
    ("wbuf", "p"),
    ("imp", "p"),
    ("iapp", "p"),
    ("lim", "p"),
    ("queue", "p"),
    ("pseq", "p"),
    ("std", "p"),
    ("n_proc", "p"),
    ("n_cur", "p"),
    ("n_meas", "p"),
    ("f_time", "p"),
    ("cables", "p"),
    ("cable_start", "p"),
    ("contact", "p"),
    ("y", "p"),
    ("ia", "p"),
    # controller call
    ("c_f", "p"),
    ("c_arg", "p"),
    ("c_res", "p"),
    ("c_iw", "p"),
    ("c_w", "p"),
    ("state_a", "p"),
    ("state_b", "p"),
    ("meas", "p"),
    ("lrow", "p"),
    ("fault", "p"),
    ("refs", "p"),
    # outputs
    ("Y", "p"),
    ("X", "p"),
    ("U", "p"),
    ("UA", "p"),
    ("limited", "p"),
    ("LOG", "p"),
    ("t_us", "p"),
    ("IMP", "p"),
    ("steps", "i"),
    ("error", "i"),
)

_CTYPE = {"i": "long long", "d": "double", "p": "void *"}

_BODY = r"""
typedef long long cint;
typedef int (*cfun)(const double **arg, double **res, cint *iw, double *w, int mem);

#define D(ptr) ((double *)(ptr))

static double now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

/* The plant's current limiter (Plant._limit): clip each axis, then scale to the amplitude bound. */
static int limit(const loop_t *s, double iq, double id, double *cq, double *cd) {
    if (!s->lim_on) { *cq = iq; *cd = id; return 0; }
    double a = s->i_axis;
    double q = iq < -a ? -a : iq, d = id < -a ? -a : id;
    q = q > a ? a : q;
    d = d > a ? a : d;
    double amp = hypot(q, d);
    if (amp > s->i_amp) { double sc = s->i_amp / amp; q = q * sc; d = d * sc; }
    *cq = q; *cd = d;
    return (q != iq || d != id);
}

static void at_stops(const double *xa, const double *lim, double *contact) {
    contact[0] = xa[0] <= lim[0]; contact[1] = xa[0] >= lim[1];
    contact[2] = xa[2] <= lim[2]; contact[3] = xa[2] >= lim[3];
}

int run_loop(loop_t *s) {
    const cint n = s->n;
    double *xa = D(s->xa), *xa_out = D(s->xa_out), *u_in = D(s->u_in), *w = D(s->wbuf);
    double *imp = D(s->imp), *iapp = D(s->iapp), *lim = D(s->lim), *queue = D(s->queue);
    double *contact = D(s->contact), *y = D(s->y), *ia = D(s->ia), *meas = D(s->meas), *lrow = D(s->lrow);
    const double *std = D(s->std), *np_ = D(s->n_proc), *nc = D(s->n_cur), *nm = D(s->n_meas);
    const double *cab = D(s->cables);
    const cint *cstart = (const cint *)s->cable_start;
    const double **c_arg = (const double **)s->c_arg;
    double **c_res = (double **)s->c_res;
    double *st_in = D(s->state_a), *st_out = D(s->state_b);
    cfun cf = (cfun)s->c_f, pf = (cfun)s->plant_f;
    cint head = 0;
    s->steps = 0;
    s->error = 0;
    for (cint k = 0; k < n; ++k) {
        /* what the controller sees at t_k */
        D(s->Y)[2 * k] = y[0]; D(s->Y)[2 * k + 1] = y[1];
        for (int j = 0; j < 4; ++j) D(s->X)[4 * k + j] = xa[j];
        D(s->UA)[2 * k] = ia[0]; D(s->UA)[2 * k + 1] = ia[1];
        /* controller step */
        meas[0] = y[0]; meas[1] = y[1];
        if (s->meas_n > 2) meas[2] = D(s->fault)[k];
        if (s->ref_in >= 0) c_arg[s->ref_in] = D(s->refs) + k * s->ref_n;
        c_arg[s->state_in] = st_in;
        c_res[s->state_out] = st_out;
        double t0 = s->timing ? now_us() : 0.0;
        int rc = cf(c_arg, c_res, (cint *)s->c_iw, D(s->c_w), 0);
        double t1 = s->timing ? now_us() : 0.0;
        if (rc) { s->error = 1; break; }
        const double *u = lrow + s->u_off;
        if (!isfinite(u[0]) || !isfinite(u[1])) { s->error = 2; break; }
        D(s->t_us)[k] = t1 - t0;
        memcpy(D(s->LOG) + k * s->log_size, lrow, sizeof(double) * (size_t)s->log_size);
        D(s->U)[2 * k] = u[0]; D(s->U)[2 * k + 1] = u[1];
        { double *tmp = st_in; st_in = st_out; st_out = tmp; }
        /* plant step (Plant.step) */
        double cq, cd;
        int limited = limit(s, u[0], u[1], &cq, &cd);
        if (s->delay) {
            u_in[0] = queue[2 * head]; u_in[1] = queue[2 * head + 1];
            queue[2 * head] = cq; queue[2 * head + 1] = cd;
            head = (head + 1) % s->delay;
        } else {
            u_in[0] = cq; u_in[1] = cd;
        }
        if (s->has_payload) memcpy(D(s->pbuf), D(s->pseq) + k * s->np, sizeof(double) * (size_t)s->np);
        if (s->proc_on) { w[0] = std[0] * np_[2 * k]; w[1] = std[1] * np_[2 * k + 1]; }
        if (s->cur_on) { w[2] = std[2] * nc[2 * k]; w[3] = std[3] * nc[2 * k + 1]; }
        if (s->has_force) {
            double fg = D(s->f_time)[2 * k], fd = D(s->f_time)[2 * k + 1];
            for (cint c = 0; c < s->n_cables; ++c) {
                if (k < cstart[c]) continue;
                const double *cb = cab + 7 * c;  /* CABLE_FIELDS of maglev_ocp.loop.compiled */
                double cg = cb[0] - cb[1] * (xa[0] - cb[2]) - cb[3] * xa[1];
                double cdd = -cb[4] * (xa[2] - cb[5]) - cb[6] * xa[3];
                fg = fg + cg; fd = fd + cdd;
            }
            if (!s->proc_on) { w[0] = 0.0; w[1] = 0.0; }
            w[0] += fg; w[1] += fd;
        }
        if (pf((const double **)s->p_arg, (double **)s->p_res, (cint *)s->p_iw, D(s->p_w), 0)) { s->error = 3; break; }
        memcpy(xa, xa_out, sizeof(double) * (size_t)s->nxa);
        /* stops: a newly hit stop is an event */
        if (imp[0] != 0.0 || imp[1] != 0.0 || imp[2] != 0.0 || imp[3] != 0.0) {
            for (int j = 0; j < 4; ++j)
                if (imp[j] > 0 && !contact[j]) D(s->IMP)[4 * k + j] = imp[j];
            at_stops(xa, lim, contact);
        } else if (s->stops_on && (contact[0] || contact[1] || contact[2] || contact[3])) {
            at_stops(xa, lim, contact);
        }
        /* encoder (Plant._measure) */
        double g = xa[0], d = xa[2];
        if (s->meas_on) {
            if (!s->lock_g) g += std[4] * nm[2 * k];
            if (!s->lock_d) d += std[5] * nm[2 * k + 1];
        }
        /* + 0.0: a reading rounded to zero is +0.0, as Python's round() (an int) times q gives */
        if (s->q != 0.0) { g = nearbyint(g / s->q) * s->q + 0.0; d = nearbyint(d / s->q) * s->q + 0.0; }
        y[0] = g; y[1] = d;
        ia[0] = iapp[0]; ia[1] = iapp[1];
        D(s->limited)[k] = (double)limited;
        s->steps = k + 1;
    }
    return (int)s->error;
}
"""


def loop_c_source() -> str:
    """The C file of ``run_loop`` (struct ``loop_t`` from :data:`LOOP_FIELDS`, then the loop)."""
    fields = "\n".join(f"    {_CTYPE[t]} {name};" for name, t in LOOP_FIELDS)
    head = (
        "/* maglev_loop.c -- generated by maglev-ocp (maglev_ocp.codegen.loop_c). Do not edit.\n"
        " * One closed-loop scenario in one call: plant step + controller step + logging. */\n"
        "#define _POSIX_C_SOURCE 199309L\n"
        "#include <math.h>\n#include <string.h>\n#include <time.h>\n\n"
        f"typedef struct {{\n{fields}\n}} loop_t;\n"
    )
    return head + _BODY


__all__ = ["LOOP_FIELDS", "loop_c_source"]
