/* Plain scalar C loops of the suite's fixed-step schemes: the hardware reference of `foucault-bench perf`.
 *
 * The model arithmetic is the suite's, written out literally (models/linear.py, models/spherical.py,
 * models/base.py): every expression keeps the operand order of its Python twin, including the multiplications
 * by the zero velocities and zero rotation components that the one-source models carry, so that a C loop and
 * the numba kernel compute the same states (bitwise: neither contracts a*b+c into an FMA). The schemes
 * (integrators/methods/{explicit_euler,symplectic_euler,rk4,heun3,nystrom4,verlet,yoshida4,composition6,boris}.py,
 * integrators/explicit_rk.py, integrators/gauss.py) and the loop
 * (integrators/fixed_step.py) are written as a C programmer writes them for speed:
 *   - every loop invariant computed once before the loop (make_consts, <scheme>_setup): the parameters read
 *     into local scalars, sqrt(k2) for the Gauss solves, the Boris rotation's cosine and sine, and for the
 *     Verlet sequences each sub-step gamma_i h and each rotation, on the plane as tan(a/2) and sin a (three shears), on the
 *     sphere as a 3x3 matrix (R = cos a I + sin a [n]x + (1 - cos a) n n^T; 9 multiplications and 6 additions
 *     per rotation instead of Rodrigues' vector form's 18 and 12);
 *   - a composition (yoshida4: 3 Verlet sub-steps, composition6: 9) stays in the canonical variables from its
 *     first sub-step to its last and merges the two half rotations between neighbouring sub-steps into one
 *     (rotations about one axis add): s + 1 rotations of r and p per step instead of 2s, and one change of
 *     variables (v <-> p) instead of s;
 *   - four scalar doubles of state, two nested loops (output rows, steps per row: no modulo per step), the
 *     divergence test after every step, the state written to `out` once per row;
 *   - sqrt, not pow(x, 0.5).
 * The numba steps compute the same way (integrators/methods/verlet.py verlet_sequences), so the states stay bitwise equal.
 *
 * Each (model, scheme) pair exports two functions:
 *   fb_<model>_<scheme>(state0, p, h, n_steps, stride, out, radius_bound, steps_done) -> status
 *   fb_<model>_<scheme>_monitor(..., turning, n_turning_max, n_turning, max_rel, slope) -> status
 * status 0 = ok, 1 = diverged; n_steps a multiple of stride; the monitored loop streams the same verdict
 * ingredients as the kernel (max relative energy error, Welford slope, turning points on the cubic Hermite
 * interpolant).
 */
#include <math.h>
#include <stdint.h>

#define MAX_SUB_STEPS 35 /* composition10 */
#define MAX_ROTATIONS 39 /* composition10: 4 sequences (SEQUENCE_SUB_STEPS below), each one rotation more than sub-steps */

typedef struct {
    double g, length, k2, wx, wy, wz, c;  /* models/parameters.py PARAMETER_VECTOR_NAMES */
    double k;                             /* sqrt(k2): the Gauss solves' norm */
    /* Verlet sequences (integrators/methods/verlet.py verlet_sequences): sub-steps gamma_i h and the merged rotations */
    double sub_h[MAX_SUB_STEPS];
    double tan_r[MAX_ROTATIONS], sin_r[MAX_ROTATIONS]; /* plane: rotation by -c_i a h about z (shears) */
    double rot[MAX_ROTATIONS][9];                              /* sphere: rotation by -c_i |w| h, row-major */
    double cos_boris, sin_boris;                               /* plane Boris: velocity turned by -2 a h */
} consts;

static consts make_consts(const double *p) {
    consts k;
    k.g = p[0]; k.length = p[1]; k.k2 = p[2]; k.wx = p[3]; k.wy = p[4]; k.wz = p[5]; k.c = p[6];
    k.k = sqrt(k.k2);
    return k;
}

/* ---- per-scheme constants, computed once per run ---- */

static void no_setup(consts *k, double h) { (void)k; (void)h; }

/* integrators/methods/verlet.py _rotation: R = cos a I + sin a [n]x + (1 - cos a) n n^T, a = -|w| c h */
static void rotation_matrix(const consts *k, double c, double h, double *r) {
    double rate = sqrt(k->wx * k->wx + k->wy * k->wy + k->wz * k->wz);
    if (rate == 0.0) {
        const double identity[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
        for (int i = 0; i < 9; i++) r[i] = identity[i];
        return;
    }
    double nx = k->wx / rate, ny = k->wy / rate, nz = k->wz / rate;
    double angle = -c * rate * h;
    double cos_a = cos(angle), sin_a = sin(angle), u = 1.0 - cos_a;
    r[0] = cos_a + u * nx * nx; r[1] = u * nx * ny - sin_a * nz; r[2] = u * nx * nz + sin_a * ny;
    r[3] = u * ny * nx + sin_a * nz; r[4] = cos_a + u * ny * ny; r[5] = u * ny * nz - sin_a * nx;
    r[6] = u * nz * nx - sin_a * ny; r[7] = u * nz * ny + sin_a * nx; r[8] = cos_a + u * nz * nz;
}

/* integrators/methods/verlet.py rotation_coefficients: c_0 = g_1/2, c_i = (g_i + g_(i+1))/2, c_n = g_n/2; the
 * sequence's sub-steps stored from sub_h[step0], its rotations from row row0 */
static void sequence_setup(consts *k, double h, const double *gamma, int step0, int row0, int n) {
    for (int i = 0; i < n; i++) k->sub_h[step0 + i] = gamma[i] * h;
    for (int i = 0; i <= n; i++) {
        double c = i == 0 ? 0.5 * gamma[0] : (i == n ? 0.5 * gamma[n - 1] : 0.5 * (gamma[i - 1] + gamma[i]));
        double angle = -c * k->wz * h;
        k->tan_r[row0 + i] = tan(0.5 * angle);
        k->sin_r[row0 + i] = sin(angle);
        rotation_matrix(k, c, h, k->rot[row0 + i]);
    }
}

/* integrators/composition.py triple_jump(4): g_1 = g_3 = 1/(2 - 2^(1/3)), g_2 = 1 - 2 g_1 (as Python rounds them) */
static const double YOSHIDA4[3] = {1.3512071919596578, -1.7024143839193155, 1.3512071919596578};
/* integrators/methods/composition6.py: Kahan & Li s9odr6a */
static const double COMPOSITION6[9] = {
    0.39216144400731413927925056, 0.33259913678935943859974864, -0.70624617255763935980996482,
    0.08221359629355080023149045, 0.79854399093482996339895035, 0.08221359629355080023149045,
    -0.70624617255763935980996482, 0.33259913678935943859974864, 0.39216144400731413927925056};
static const double VERLET[1] = {1.0};

static void verlet_setup(consts *k, double h) { sequence_setup(k, h, VERLET, 0, 0, 1); }
static void yoshida4_setup(consts *k, double h) { sequence_setup(k, h, YOSHIDA4, 0, 0, 3); }
static void composition6_setup(consts *k, double h) { sequence_setup(k, h, COMPOSITION6, 0, 0, 9); }
static void boris_setup(consts *k, double h) {
    k->cos_boris = cos(-2.0 * k->wz * h);
    k->sin_boris = sin(-2.0 * k->wz * h);
}
#define explicit_euler_setup no_setup
#define symplectic_euler_setup no_setup
#define rk4_setup no_setup
#define heun3_setup no_setup
#define nystrom4_setup no_setup
#define implicit_midpoint_setup no_setup
#define gauss_legendre4_setup no_setup

/* ---- models: free force, geometry, energy (models/linear.py, models/spherical.py, models/base.py) ---- */

static inline void linear_force(const consts *k, double x, double y, double z, double vx, double vy, double vz,
                                double *fx, double *fy, double *fz) {
    (void)vz;
    *fx = -k->k2 * x + 2.0 * k->wz * vy;
    *fy = -k->k2 * y - 2.0 * k->wz * vx;
    *fz = 0.0 * z;
}

static inline void spherical_force(const consts *k, double x, double y, double z, double vx, double vy,
                                   double vz, double *fx, double *fy, double *fz) {
    double wx = k->wx, wy = k->wy, wz = k->wz, c = k->c;
    double wrx = wy * z - wz * y, wry = wz * x - wx * z, wrz = wx * y - wy * x;
    double wvx = wy * vz - wz * vy, wvy = wz * vx - wx * vz, wvz = wx * vy - wy * vx;
    double cx = wy * wrz - wz * wry, cy = wz * wrx - wx * wrz, cz = wx * wry - wy * wrx;
    *fx = -2.0 * wvx - c * cx;
    *fy = -2.0 * wvy - c * cy;
    *fz = -k->g - 2.0 * wvz - c * cz;
}

static inline void sphere_height(const consts *k, double x, double y, double vx, double vy, double *z, double *vz) {
    double length = k->length;
    *z = -sqrt(length * length - x * x - y * y);
    *vz = -(x * vx + y * vy) / *z;
}

static inline void linear_acceleration(const consts *k, double x, double y, double vx, double vy,
                                       double *ax, double *ay) {
    double fz;
    linear_force(k, x, y, 0.0, vx, vy, 0.0, ax, ay, &fz);
}

static inline void spherical_acceleration(const consts *k, double x, double y, double vx, double vy,
                                          double *ax, double *ay) {
    double z, vz, fx, fy, fz;
    sphere_height(k, x, y, vx, vy, &z, &vz);
    spherical_force(k, x, y, z, vx, vy, vz, &fx, &fy, &fz);
    double length = k->length;
    double mu = -(vx * vx + vy * vy + vz * vz + x * fx + y * fy + z * fz) / (length * length);
    *ax = fx + mu * x;
    *ay = fy + mu * y;
}

static inline double linear_energy(const consts *k, double x, double y, double vx, double vy) {
    return 0.5 * (vx * vx + vy * vy) + 0.5 * k->k2 * (x * x + y * y);
}

static inline double spherical_energy(const consts *k, double x, double y, double vx, double vy) {
    double z, vz;
    sphere_height(k, x, y, vx, vy, &z, &vz);
    double wx = k->wx, wy = k->wy, wz = k->wz;
    double wrx = wy * z - wz * y, wry = wz * x - wx * z, wrz = wx * y - wy * x;
    double kinetic = 0.5 * (vx * vx + vy * vy + vz * vz);
    return kinetic + k->g * z - 0.5 * k->c * (wrx * wrx + wry * wry + wrz * wrz);
}

/* Model.numba_kick: -grad U(r) = F(r, 0) + w_c x (w_c x r); w_c = (0, 0, a) on the plane, full w on the sphere */
#define DEFINE_KICK(model, WX, WY)                                                                            \
    static inline void model##_kick(const consts *k, double x, double y, double z,                           \
                                    double *kx, double *ky, double *kz) {                                    \
        double wx = WX, wy = WY, wz = k->wz, fx, fy, fz;                                                     \
        model##_force(k, x, y, z, 0.0, 0.0, 0.0, &fx, &fy, &fz);                                             \
        double wrx = wy * z - wz * y, wry = wz * x - wx * z, wrz = wx * y - wy * x;                          \
        *kx = fx + wy * wrz - wz * wry;                                                                      \
        *ky = fy + wz * wrx - wx * wrz;                                                                      \
        *kz = fz + wx * wry - wy * wrx;                                                                      \
    }
DEFINE_KICK(linear, 0.0, 0.0)
DEFINE_KICK(spherical, k->wx, k->wy)

/* ---- schemes: one step (x, y, vx, vy) -> next, in place; rk4 and heun3 as increments, which the loop adds
 * with compensated summation (integrators/explicit_rk.py make_increment, COMPENSATED_ADVANCE); nystrom4 too ---- */

#define DEFINE_RUNGE_KUTTA_STEPS(model)                                                                       \
    static inline void model##_explicit_euler_step(const consts *k, double h, double *x, double *y,          \
                                                   double *vx, double *vy) {                                 \
        double ax, ay;                                                                                        \
        model##_acceleration(k, *x, *y, *vx, *vy, &ax, &ay);                                                  \
        double xn = *x + h * *vx, yn = *y + h * *vy;                                                          \
        *vx = *vx + h * ax;                                                                                   \
        *vy = *vy + h * ay;                                                                                   \
        *x = xn;                                                                                              \
        *y = yn;                                                                                              \
    }                                                                                                         \
    static inline void model##_symplectic_euler_step(const consts *k, double h, double *x, double *y,        \
                                                     double *vx, double *vy) {                               \
        double ax, ay;                                                                                        \
        model##_acceleration(k, *x, *y, *vx, *vy, &ax, &ay);                                                  \
        double vxn = *vx + h * ax, vyn = *vy + h * ay;                                                        \
        *x = *x + h * vxn;                                                                                    \
        *y = *y + h * vyn;                                                                                    \
        *vx = vxn;                                                                                            \
        *vy = vyn;                                                                                            \
    }                                                                                                         \
    static inline void model##_rk4_increment(const consts *k, double h, double x, double y, double vx,       \
                                             double vy, double *d) {                                         \
        double half = 0.5 * h;                                                                                \
        double k1ax, k1ay, k2ax, k2ay, k3ax, k3ay, k4ax, k4ay;                                                \
        model##_acceleration(k, x, y, vx, vy, &k1ax, &k1ay);                                                  \
        double x2 = x + half * vx, y2 = y + half * vy, vx2 = vx + half * k1ax, vy2 = vy + half * k1ay;        \
        model##_acceleration(k, x2, y2, vx2, vy2, &k2ax, &k2ay);                                              \
        double x3 = x + half * vx2, y3 = y + half * vy2, vx3 = vx + half * k2ax, vy3 = vy + half * k2ay;      \
        model##_acceleration(k, x3, y3, vx3, vy3, &k3ax, &k3ay);                                              \
        double x4 = x + h * vx3, y4 = y + h * vy3, vx4 = vx + h * k3ax, vy4 = vy + h * k3ay;                  \
        model##_acceleration(k, x4, y4, vx4, vy4, &k4ax, &k4ay);                                              \
        double sixth = h / 6.0;                                                                               \
        d[0] = sixth * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4);                                                    \
        d[1] = sixth * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4);                                                    \
        d[2] = sixth * (k1ax + 2.0 * k2ax + 2.0 * k3ax + k4ax);                                               \
        d[3] = sixth * (k1ay + 2.0 * k2ay + 2.0 * k3ay + k4ay);                                               \
    }                                                                                                         \
    /* integrators/methods/heun3.py as integrators/explicit_rk.py generates it: rows (h/D)(integer sums) */    \
    static inline void model##_heun3_increment(const consts *k, double h, double x, double y, double vx,     \
                                               double vy, double *d) {                                       \
        double third = h / 3.0, quarter = h / 4.0;                                                            \
        double k1ax, k1ay, k2ax, k2ay, k3ax, k3ay;                                                            \
        model##_acceleration(k, x, y, vx, vy, &k1ax, &k1ay);                                                  \
        double x2 = x + third * vx, y2 = y + third * vy, vx2 = vx + third * k1ax, vy2 = vy + third * k1ay;    \
        model##_acceleration(k, x2, y2, vx2, vy2, &k2ax, &k2ay);                                              \
        double x3 = x + third * (2.0 * vx2), y3 = y + third * (2.0 * vy2);                                    \
        double vx3 = vx + third * (2.0 * k2ax), vy3 = vy + third * (2.0 * k2ay);                              \
        model##_acceleration(k, x3, y3, vx3, vy3, &k3ax, &k3ay);                                              \
        d[0] = quarter * (vx + 3.0 * vx3);                                                                    \
        d[1] = quarter * (vy + 3.0 * vy3);                                                                    \
        d[2] = quarter * (k1ax + 3.0 * k3ax);                                                                 \
        d[3] = quarter * (k1ay + 3.0 * k3ay);                                                                 \
    }                                                                                                         \
    /* integrators/methods/nystrom4.py: the general Runge-Kutta-Nystrom method, stages at stage velocities */ \
    static inline void model##_nystrom4_increment(const consts *k, double h, double x, double y, double vx,  \
                                                  double vy, double *d) {                                    \
        double half = 0.5 * h, eighth_h2 = 0.125 * h * h;                                                     \
        double k1x, k1y, k2x, k2y, k3x, k3y, k4x, k4y;                                                        \
        model##_acceleration(k, x, y, vx, vy, &k1x, &k1y);                                                    \
        double x2 = x + half * vx + eighth_h2 * k1x, y2 = y + half * vy + eighth_h2 * k1y;                    \
        model##_acceleration(k, x2, y2, vx + half * k1x, vy + half * k1y, &k2x, &k2y);                        \
        model##_acceleration(k, x2, y2, vx + half * k2x, vy + half * k2y, &k3x, &k3y);                        \
        double half_h2 = 0.5 * h * h;                                                                         \
        model##_acceleration(k, x + h * vx + half_h2 * k3x, y + h * vy + half_h2 * k3y, vx + h * k3x,         \
                             vy + h * k3y, &k4x, &k4y);                                                       \
        double sixth_h2 = h * h / 6.0, sixth = h / 6.0;                                                       \
        d[0] = h * vx + sixth_h2 * (k1x + k2x + k3x);                                                         \
        d[1] = h * vy + sixth_h2 * (k1y + k2y + k3y);                                                         \
        d[2] = sixth * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);                                                   \
        d[3] = sixth * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);                                                   \
    }
DEFINE_RUNGE_KUTTA_STEPS(linear)
DEFINE_RUNGE_KUTTA_STEPS(spherical)

/* ---- Verlet sequences (integrators/methods/verlet.py verlet_sequences): Verlet, yoshida4, composition6 ---- */

/* plane: canonical p = v + a z x r; per sub-step the merged rotation then kick, drift, kick */
/* verlet.py _plane_parts turn: the rotation as three shears of r and their inverse transposes on p */
static inline void shear_turn(double t, double s, double *x, double *y, double *px, double *py) {
    *x -= t * *y;
    *py += t * *px;
    *y += s * *x;
    *px -= s * *py;
    *x -= t * *y;
    *py += t * *px;
}

static inline void linear_sequence(const consts *k, int step0, int row0, int n, double *x_, double *y_, double *vx_,
                                   double *vy_) {
    double a = k->wz, x = *x_, y = *y_, fx, fy, fz;
    double px = *vx_ - a * y, py = *vy_ + a * x;
    for (int i = 0; i < n; i++) {
        double h = k->sub_h[step0 + i];
        shear_turn(k->tan_r[row0 + i], k->sin_r[row0 + i], &x, &y, &px, &py);
        linear_kick(k, x, y, 0.0, &fx, &fy, &fz);
        px += 0.5 * h * fx;
        py += 0.5 * h * fy;
        x += h * px;
        y += h * py;
        linear_kick(k, x, y, 0.0, &fx, &fy, &fz);
        px = px + 0.5 * h * fx;
        py = py + 0.5 * h * fy;
    }
    shear_turn(k->tan_r[row0 + n], k->sin_r[row0 + n], &x, &y, &px, &py);
    *x_ = x;
    *y_ = y;
    *vx_ = px + a * y;
    *vy_ = py - a * x;
}

/* the precomputed 3x3 matrix applied (9 multiplications, 6 additions) */
static inline void rotate(const double *r, double *vx, double *vy, double *vz) {
    double rx = r[0] * *vx + r[1] * *vy + r[2] * *vz;
    double ry = r[3] * *vx + r[4] * *vy + r[5] * *vz;
    double rz = r[6] * *vx + r[7] * *vy + r[8] * *vz;
    *vx = rx;
    *vy = ry;
    *vz = rz;
}

/* sphere: canonical p = v + w x r in 3-D; per sub-step the merged rotation then RATTLE */
static inline void spherical_sequence(const consts *k, int step0, int row0, int n, double *x_, double *y_,
                                      double *vx_, double *vy_) {
    double wx = k->wx, wy = k->wy, wz = k->wz, length = k->length, l2 = length * length;
    double x = *x_, y = *y_, vx = *vx_, vy = *vy_, fx, fy, fz;
    double z = -sqrt(l2 - x * x - y * y);
    double vz = -(x * vx + y * vy) / z;
    double px = vx + wy * z - wz * y, py = vy + wz * x - wx * z, pz = vz + wx * y - wy * x;
    for (int i = 0; i < n; i++) {
        double h = k->sub_h[step0 + i];
        rotate(k->rot[row0 + i], &x, &y, &z);
        rotate(k->rot[row0 + i], &px, &py, &pz);
        spherical_kick(k, x, y, z, &fx, &fy, &fz);
        double qx = x + h * (px + 0.5 * h * fx), qy = y + h * (py + 0.5 * h * fy), qz = z + h * (pz + 0.5 * h * fz);
        double qr = qx * x + qy * y + qz * z;
        double excess = qx * qx + qy * qy + qz * qz - l2;
        double cc = -excess / (qr + sqrt(qr * qr - l2 * excess));
        double xn = qx + cc * x, yn = qy + cc * y, zn = qz + cc * z;
        px = (xn - x) / h;
        py = (yn - y) / h;
        pz = (zn - z) / h;
        spherical_kick(k, xn, yn, zn, &fx, &fy, &fz);
        px += 0.5 * h * fx;
        py += 0.5 * h * fy;
        pz += 0.5 * h * fz;
        double nu = -(xn * px + yn * py + zn * pz) / l2;
        px += nu * xn;
        py += nu * yn;
        pz += nu * zn;
        x = xn; y = yn; z = zn;
    }
    rotate(k->rot[row0 + n], &x, &y, &z);
    rotate(k->rot[row0 + n], &px, &py, &pz);
    *x_ = x;
    *y_ = y;
    *vx_ = px - (wy * z - wz * y);
    *vy_ = py - (wz * x - wx * z);
}

#define DEFINE_SEQUENCE_STEPS(model)                                                                          \
    static inline void model##_verlet_step(const consts *k, double h, double *x, double *y, double *vx,      \
                                           double *vy) {                                                     \
        (void)h;                                                                                              \
        model##_sequence(k, 0, 0, 1, x, y, vx, vy);                                                                 \
    }                                                                                                         \
    static inline void model##_yoshida4_step(const consts *k, double h, double *x, double *y, double *vx,    \
                                             double *vy) {                                                   \
        (void)h;                                                                                              \
        model##_sequence(k, 0, 0, 3, x, y, vx, vy);                                                                 \
    }                                                                                                         \
    static inline void model##_composition6_step(const consts *k, double h, double *x, double *y,            \
                                                 double *vx, double *vy) {                                   \
        (void)h;                                                                                              \
        model##_sequence(k, 0, 0, 9, x, y, vx, vy);                                                                 \
    }
DEFINE_SEQUENCE_STEPS(linear)
DEFINE_SEQUENCE_STEPS(spherical)

/* ---- Boris (integrators/methods/boris.py): drift, half kick, Coriolis rotation of v, half kick, drift ---- */

static inline void linear_boris_step(const consts *k, double h, double *x_, double *y_, double *vx_,
                                     double *vy_) {
    double half = 0.5 * h, x = *x_, y = *y_, vx = *vx_, vy = *vy_, fx, fy, fz, t;
    double c = k->cos_boris, s = k->sin_boris;
    x += half * vx;
    y += half * vy;
    linear_force(k, x, y, 0.0, 0.0, 0.0, 0.0, &fx, &fy, &fz);
    vx += half * fx;
    vy += half * fy;
    t = c * vx - s * vy; vy = s * vx + c * vy; vx = t;
    vx = vx + half * fx;
    vy = vy + half * fy;
    *x_ = x + half * vx;
    *y_ = y + half * vy;
    *vx_ = vx;
    *vy_ = vy;
}

/* integrators/methods/boris.py _geodesic: a great circle at constant speed for a time tau */
static inline void geodesic(double *x, double *y, double *z, double *vx, double *vy, double *vz, double length,
                            double tau) {
    double speed = sqrt(*vx * *vx + *vy * *vy + *vz * *vz);
    if (speed == 0.0) return;
    double angle = speed * tau / length;
    double cos_a = cos(angle), sin_a = sin(angle);
    double along = length / speed * sin_a, back = -speed / length * sin_a;
    double xn = *x * cos_a + *vx * along, yn = *y * cos_a + *vy * along, zn = *z * cos_a + *vz * along;
    *vx = *x * back + *vx * cos_a;
    *vy = *y * back + *vy * cos_a;
    *vz = *z * back + *vz * cos_a;
    *x = xn;
    *y = yn;
    *z = zn;
}

static inline void spherical_boris_step(const consts *k, double h, double *x_, double *y_, double *vx_,
                                        double *vy_) {
    double half = 0.5 * h, length = k->length, wx = k->wx, wy = k->wy, wz = k->wz;
    double x = *x_, y = *y_, vx = *vx_, vy = *vy_, fx, fy, fz;
    double z = -sqrt(length * length - x * x - y * y);
    double vz = -(x * vx + y * vy) / z;
    geodesic(&x, &y, &z, &vx, &vy, &vz, length, half);
    spherical_force(k, x, y, z, 0.0, 0.0, 0.0, &fx, &fy, &fz);
    double radial = (fx * x + fy * y + fz * z) / (length * length);
    fx -= radial * x;
    fy -= radial * y;
    fz -= radial * z;
    vx += half * fx;
    vy += half * fy;
    vz += half * fz;
    double nx = x / length, ny = y / length, nz = z / length;
    double angle = -2.0 * (wx * nx + wy * ny + wz * nz) * h;
    double cos_a = cos(angle), sin_a = sin(angle);
    double tx = cos_a * vx + sin_a * (ny * vz - nz * vy);
    double ty = cos_a * vy + sin_a * (nz * vx - nx * vz);
    double tz = cos_a * vz + sin_a * (nx * vy - ny * vx);
    vx = tx + half * fx;
    vy = ty + half * fy;
    vz = tz + half * fz;
    geodesic(&x, &y, &z, &vx, &vy, &vz, length, half);
    *x_ = x;
    *y_ = y;
    *vx_ = vx;
    *vy_ = vy;
}

/* ---- Gauss-Legendre collocation: fixed-point sweeps, then simplified Newton to round-off (integrators/gauss.py) ---- */

#define NEWTON_START_INCREMENT 1.0e-4
#define NEWTON_ROUNDOFF 0x1p-52
#define CONVERGED_INCREMENT 1.0e-12
#define DIVERGED_INCREMENT 1.0e3
#define MAX_SWEEPS 100000
#define NEWTON_ITERATIONS 20
#define DIFFERENCE_STEP 0x1p-26
#define SQRT3 1.7320508075688772 /* math.sqrt(3.0) */
/* the solve's pieces are inlined, as numba inlines them (inline="always"): left to gcc's heuristics, the stage
   images and the increments of the two-stage method stay calls whose arrays live in memory (1.2-1.5x slower) */
#define GAUSS_INLINE static inline __attribute__((always_inline))
#define GAUSS2_S (SQRT3 / 6.0)

static inline double squared_norm(double dx, double dy, double dvx, double dvy, double k) {
    return k * k * (dx * dx + dy * dy) + dvx * dvx + dvy * dvy;
}

/* gauss.py _newton_converged */
GAUSS_INLINE int newton_converged(double change, double previous) {
    return change <= NEWTON_ROUNDOFF || (change >= previous && previous <= CONVERGED_INCREMENT);
}

/* gauss.py _inverse2 and _product2: 2x2 matrices as row-major arrays */
GAUSS_INLINE void inverse2(double m11, double m12, double m21, double m22, double *r) {
    double det = m11 * m22 - m12 * m21;
    r[0] = m22 / det; r[1] = -m12 / det; r[2] = -m21 / det; r[3] = m11 / det;
}

GAUSS_INLINE void product2(const double *a, const double *b, double *r) {
    r[0] = a[0] * b[0] + a[1] * b[2]; r[1] = a[0] * b[1] + a[1] * b[3];
    r[2] = a[2] * b[0] + a[3] * b[2]; r[3] = a[2] * b[1] + a[3] * b[3];
}

/* integrators/fixed_step.py compensated_add: *total += increment, with the compensation *c (Kahan) */
static inline void compensated_add(double *total, double increment, double *c) {
    *c += increment;
    double new_total = *total + *c;
    *c = *c + (*total - new_total);
    *total = new_total;
}

/* the increments h sum b_i f(Y_i), added by the loop with compensated summation (gauss.py make_increment) */
#define DEFINE_GAUSS_STEPS(model)                                                                             \
    /* gauss.py _difference_jacobian: j = (dax/dx, dax/dy, day/dx, day/dy, dax/dvx, dax/dvy, day/dvx, day/dvy) */ \
    GAUSS_INLINE void model##_difference_jacobian(const consts *k, double x, double y, double vx, double vy,  \
                                                   double ax, double ay, double dr, double dv, double *j) {  \
        double bx, by, step = (x + dr) - x;                                                                   \
        model##_acceleration(k, x + step, y, vx, vy, &bx, &by);                                               \
        j[0] = (bx - ax) / step; j[2] = (by - ay) / step;                                                     \
        step = (y + dr) - y;                                                                                  \
        model##_acceleration(k, x, y + step, vx, vy, &bx, &by);                                               \
        j[1] = (bx - ax) / step; j[3] = (by - ay) / step;                                                     \
        step = (vx + dv) - vx;                                                                                \
        model##_acceleration(k, x, y, vx + step, vy, &bx, &by);                                               \
        j[4] = (bx - ax) / step; j[6] = (by - ay) / step;                                                     \
        step = (vy + dv) - vy;                                                                                \
        model##_acceleration(k, x, y, vx, vy + step, &bx, &by);                                               \
        j[5] = (bx - ax) / step; j[7] = (by - ay) / step;                                                     \
    }                                                                                                         \
    /* gauss.py _midpoint_increment image: W -> h/2 f(y + W) */                                               \
    GAUSS_INLINE void model##_midpoint_image(const consts *k, double x, double y, double vx, double vy,      \
                                              const double *w, double hh, double *n) {                        \
        double mvx = vx + w[2], mvy = vy + w[3], fx, fy;                                                      \
        model##_acceleration(k, x + w[0], y + w[1], mvx, mvy, &fx, &fy);                                      \
        n[0] = hh * mvx; n[1] = hh * mvy; n[2] = hh * fx; n[3] = hh * fy;                                     \
    }                                                                                                         \
    GAUSS_INLINE void model##_implicit_midpoint_increment(const consts *k, double h, double x, double y,    \
                                                           double vx, double vy, double *d) {                \
        double ax, ay, kk = k->k, hh = 0.5 * h, w[4], n[4], j[8], inv[4];                                     \
        model##_acceleration(k, x, y, vx, vy, &ax, &ay);                                                      \
        double scale = kk * (fabs(x) + fabs(y)) + fabs(vx) + fabs(vy) + 1e-300;                               \
        w[0] = hh * vx; w[1] = hh * vy; w[2] = hh * ax; w[3] = hh * ay;                                       \
        double change = INFINITY;                                                                             \
        for (int sweep = 0; sweep < MAX_SWEEPS; sweep++) {                                                    \
            model##_midpoint_image(k, x, y, vx, vy, w, hh, n);                                                \
            change = sqrt(squared_norm(n[0] - w[0], n[1] - w[1], n[2] - w[2], n[3] - w[3], kk)) / scale;       \
            w[0] = n[0]; w[1] = n[1]; w[2] = n[2]; w[3] = n[3];                                               \
            if (change <= NEWTON_START_INCREMENT || !(change <= DIVERGED_INCREMENT)) break;                   \
        }                                                                                                     \
        if (!(change <= NEWTON_START_INCREMENT)) { d[0] = d[1] = d[2] = d[3] = NAN; return; }                 \
        model##_difference_jacobian(k, x, y, vx, vy, ax, ay, DIFFERENCE_STEP * scale / kk,                    \
                                    DIFFERENCE_STEP * scale, j);                                              \
        double hh2 = hh * hh;                                                                                 \
        inverse2(1.0 - hh * j[4] - hh2 * j[0], -hh * j[5] - hh2 * j[1], -hh * j[6] - hh2 * j[2],              \
                 1.0 - hh * j[7] - hh2 * j[3], inv);                                                          \
        double previous = INFINITY;                                                                           \
        int converged = 0;                                                                                    \
        for (int iteration = 0; iteration < NEWTON_ITERATIONS; iteration++) {                                 \
            model##_midpoint_image(k, x, y, vx, vy, w, hh, n);                                                \
            double gx = n[0] - w[0], gy = n[1] - w[1], gvx = n[2] - w[2], gvy = n[3] - w[3];                  \
            double cx = gvx + hh * (j[0] * gx + j[1] * gy);                                                   \
            double cy = gvy + hh * (j[2] * gx + j[3] * gy);                                                   \
            double dvx = inv[0] * cx + inv[1] * cy, dvy = inv[2] * cx + inv[3] * cy;                          \
            double dx = gx + hh * dvx, dy = gy + hh * dvy;                                                    \
            change = sqrt(squared_norm(dx, dy, dvx, dvy, kk)) / scale;                                        \
            w[0] = w[0] + dx; w[1] = w[1] + dy; w[2] = w[2] + dvx; w[3] = w[3] + dvy;                         \
            converged = newton_converged(change, previous);                                                   \
            if (converged) break;                                                                             \
            previous = change;                                                                                \
        }                                                                                                     \
        if (!converged) { d[0] = d[1] = d[2] = d[3] = NAN; return; }                                          \
        model##_midpoint_image(k, x, y, vx, vy, w, hh, n);                                                    \
        d[0] = 2.0 * n[0]; d[1] = 2.0 * n[1]; d[2] = 2.0 * n[2]; d[3] = 2.0 * n[3];                          \
    }                                                                                                         \
    /* gauss.py _gauss2_increment image: K -> f(y + h A K); kk[0..3] = K1, kk[4..7] = K2 */                   \
    GAUSS_INLINE void model##_gauss2_image(const consts *k, double x, double y, double vx, double vy,        \
                                            const double *kk, double h, double *n) {                          \
        double s = GAUSS2_S;                                                                                  \
        double qx = 0.25 * (kk[0] + kk[4]), qy = 0.25 * (kk[1] + kk[5]);                                      \
        double qvx = 0.25 * (kk[2] + kk[6]), qvy = 0.25 * (kk[3] + kk[7]);                                    \
        n[0] = vx + h * (qvx - s * kk[6]); n[1] = vy + h * (qvy - s * kk[7]);                                 \
        n[4] = vx + h * (qvx + s * kk[2]); n[5] = vy + h * (qvy + s * kk[3]);                                 \
        model##_acceleration(k, x + h * (qx - s * kk[4]), y + h * (qy - s * kk[5]), n[0], n[1], &n[2], &n[3]); \
        model##_acceleration(k, x + h * (qx + s * kk[0]), y + h * (qy + s * kk[1]), n[4], n[5], &n[6], &n[7]); \
    }                                                                                                         \
    GAUSS_INLINE void model##_gauss_legendre4_increment(const consts *k, double h, double x, double y,      \
                                                         double vx, double vy, double *d) {                  \
        double ax, ay, kn = k->k, kk[8], n[8], j[8];                                                          \
        model##_acceleration(k, x, y, vx, vy, &ax, &ay);                                                      \
        double scale = kn * (fabs(x) + fabs(y)) + fabs(vx) + fabs(vy) + 1e-300;                               \
        kk[0] = vx; kk[1] = vy; kk[2] = ax; kk[3] = ay; kk[4] = vx; kk[5] = vy; kk[6] = ax; kk[7] = ay;       \
        double change = INFINITY;                                                                             \
        for (int sweep = 0; sweep < MAX_SWEEPS; sweep++) {                                                    \
            model##_gauss2_image(k, x, y, vx, vy, kk, h, n);                                                  \
            change = sqrt(                                                                                    \
                squared_norm(h * (n[0] - kk[0]), h * (n[1] - kk[1]), h * (n[2] - kk[2]), h * (n[3] - kk[3]), kn) + \
                squared_norm(h * (n[4] - kk[4]), h * (n[5] - kk[5]), h * (n[6] - kk[6]), h * (n[7] - kk[7]), kn)) \
                / scale;                                                                                      \
            for (int i = 0; i < 8; i++) kk[i] = n[i];                                                         \
            if (change <= NEWTON_START_INCREMENT || !(change <= DIVERGED_INCREMENT)) break;                   \
        }                                                                                                     \
        if (!(change <= NEWTON_START_INCREMENT)) { d[0] = d[1] = d[2] = d[3] = NAN; return; }                 \
        model##_difference_jacobian(k, x, y, vx, vy, ax, ay, DIFFERENCE_STEP * scale / kn,                    \
                                    DIFFERENCE_STEP * scale, j);                                              \
        double a12 = 0.25 - GAUSS2_S, a21 = 0.25 + GAUSS2_S, h2 = h * h;                                      \
        double d11 = h2 * (0.0625 + a12 * a21), d12 = h2 * (0.5 * a12), d21 = h2 * (0.5 * a21);               \
        double q[4] = {1.0 - 0.25 * h * j[4] - d11 * j[0], -0.25 * h * j[5] - d11 * j[1],                     \
                       -0.25 * h * j[6] - d11 * j[2], 1.0 - 0.25 * h * j[7] - d11 * j[3]};                     \
        double p[4] = {-a12 * h * j[4] - d12 * j[0], -a12 * h * j[5] - d12 * j[1],                            \
                       -a12 * h * j[6] - d12 * j[2], -a12 * h * j[7] - d12 * j[3]};                            \
        double p21[4] = {-a21 * h * j[4] - d21 * j[0], -a21 * h * j[5] - d21 * j[1],                          \
                         -a21 * h * j[6] - d21 * j[2], -a21 * h * j[7] - d21 * j[3]};                          \
        double qi[4], t[4], wm[4], si[4];                                                                     \
        inverse2(q[0], q[1], q[2], q[3], qi);                                                                 \
        product2(p21, qi, t);                                                                                 \
        product2(t, p, wm);                                                                                   \
        inverse2(q[0] - wm[0], q[1] - wm[1], q[2] - wm[2], q[3] - wm[3], si);                                  \
        double previous = INFINITY;                                                                           \
        int converged = 0;                                                                                    \
        for (int iteration = 0; iteration < NEWTON_ITERATIONS; iteration++) {                                 \
            model##_gauss2_image(k, x, y, vx, vy, kk, h, n);                                                  \
            double g1x = n[0] - kk[0], g1y = n[1] - kk[1], g1vx = n[2] - kk[2], g1vy = n[3] - kk[3];          \
            double g2x = n[4] - kk[4], g2y = n[5] - kk[5], g2vx = n[6] - kk[6], g2vy = n[7] - kk[7];          \
            double s1x = h * (0.25 * g1x + a12 * g2x), s1y = h * (0.25 * g1y + a12 * g2y);                    \
            double s2x = h * (a21 * g1x + 0.25 * g2x), s2y = h * (a21 * g1y + 0.25 * g2y);                    \
            double c1x = g1vx + j[0] * s1x + j[1] * s1y, c1y = g1vy + j[2] * s1x + j[3] * s1y;                \
            double c2x = g2vx + j[0] * s2x + j[1] * s2y, c2y = g2vy + j[2] * s2x + j[3] * s2y;                \
            double ex = c2x - (t[0] * c1x + t[1] * c1y), ey = c2y - (t[2] * c1x + t[3] * c1y);                \
            double e2vx = si[0] * ex + si[1] * ey, e2vy = si[2] * ex + si[3] * ey;                            \
            ex = c1x - (p[0] * e2vx + p[1] * e2vy); ey = c1y - (p[2] * e2vx + p[3] * e2vy);                   \
            double e1vx = qi[0] * ex + qi[1] * ey, e1vy = qi[2] * ex + qi[3] * ey;                            \
            double e1x = g1x + h * (0.25 * e1vx + a12 * e2vx), e1y = g1y + h * (0.25 * e1vy + a12 * e2vy);    \
            double e2x = g2x + h * (a21 * e1vx + 0.25 * e2vx), e2y = g2y + h * (a21 * e1vy + 0.25 * e2vy);    \
            change = h * sqrt(squared_norm(e1x, e1y, e1vx, e1vy, kn) + squared_norm(e2x, e2y, e2vx, e2vy, kn)) \
                / scale;                                                                                      \
            kk[0] = kk[0] + e1x; kk[1] = kk[1] + e1y; kk[2] = kk[2] + e1vx; kk[3] = kk[3] + e1vy;             \
            kk[4] = kk[4] + e2x; kk[5] = kk[5] + e2y; kk[6] = kk[6] + e2vx; kk[7] = kk[7] + e2vy;             \
            converged = newton_converged(change, previous);                                                   \
            if (converged) break;                                                                             \
            previous = change;                                                                                \
        }                                                                                                     \
        if (!converged) { d[0] = d[1] = d[2] = d[3] = NAN; return; }                                          \
        model##_gauss2_image(k, x, y, vx, vy, kk, h, n);                                                      \
        double half = 0.5 * h;                                                                                \
        d[0] = half * (n[0] + n[4]);                                                                          \
        d[1] = half * (n[1] + n[5]);                                                                          \
        d[2] = half * (n[2] + n[6]);                                                                          \
        d[3] = half * (n[3] + n[7]);                                                                          \
    }
DEFINE_GAUSS_STEPS(linear)
DEFINE_GAUSS_STEPS(spherical)

/* ---- turning points (integrators/fixed_step.py _hermite, _turning_point) ---- */

static inline void hermite(double theta, double h, double p0, double v0, double p1, double v1, double *value,
                           double *slope, double *curve) {
    double t2 = theta * theta, t3 = t2 * theta;
    *value = (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + theta) * h * v0 + (-2 * t3 + 3 * t2) * p1
             + (t3 - t2) * h * v1;
    *slope = (6 * t2 - 6 * theta) * p0 + (3 * t2 - 4 * theta + 1) * h * v0 + (6 * theta - 6 * t2) * p1
             + (3 * t2 - 2 * theta) * h * v1;
    *curve = (12 * theta - 6) * (p0 - p1) + (6 * theta - 4) * h * v0 + (6 * theta - 2) * h * v1;
}

static void turning_point(double x0, double y0, double vx0, double vy0, double x1, double y1, double vx1,
                          double vy1, double h, double radial0, double radial1, double *theta_out, double *tx,
                          double *ty) {
    double theta = radial0 / (radial0 - radial1), px, sx, cx, py, sy, cy;
    for (int sweep = 0; sweep < 3; sweep++) {
        hermite(theta, h, x0, vx0, x1, vx1, &px, &sx, &cx);
        hermite(theta, h, y0, vy0, y1, vy1, &py, &sy, &cy);
        double derivative = sx * sx + sy * sy + px * cx + py * cy;
        if (derivative == 0.0) break;
        theta = fmin(1.0, fmax(0.0, theta - (px * sx + py * sy) / derivative));
    }
    hermite(theta, h, x0, vx0, x1, vx1, tx, &sx, &cx);
    hermite(theta, h, y0, vy0, y1, vy1, ty, &sy, &cy);
    *theta_out = theta;
}

/* ---- the loops (integrators/fixed_step.py build_kernel) ---- */

/* fixed_step.py _advance: a step in place, or an increment added with compensated summation */
#define PLAIN_ADVANCE(model, scheme)                                                                          \
    static inline void model##_##scheme##_advance(const consts *k, double h, double *c, double *x, double *y,\
                                                  double *vx, double *vy) {                                  \
        (void)c;                                                                                              \
        model##_##scheme##_step(k, h, x, y, vx, vy);                                                          \
    }
#define COMPENSATED_ADVANCE(model, scheme)                                                                    \
    static inline void model##_##scheme##_advance(const consts *k, double h, double *c, double *x, double *y,\
                                                  double *vx, double *vy) {                                  \
        double d[4];                                                                                          \
        model##_##scheme##_increment(k, h, *x, *y, *vx, *vy, d);                                              \
        compensated_add(x, d[0], &c[0]);                                                                      \
        compensated_add(y, d[1], &c[1]);                                                                      \
        compensated_add(vx, d[2], &c[2]);                                                                     \
        compensated_add(vy, d[3], &c[3]);                                                                     \
    }
#define PLAIN_ADVANCES(model)                                                                                 \
    PLAIN_ADVANCE(model, explicit_euler) PLAIN_ADVANCE(model, symplectic_euler)                              \
    COMPENSATED_ADVANCE(model, rk4) COMPENSATED_ADVANCE(model, heun3)                                        \
    COMPENSATED_ADVANCE(model, nystrom4) PLAIN_ADVANCE(model, verlet)                                              \
    PLAIN_ADVANCE(model, yoshida4) PLAIN_ADVANCE(model, composition6) PLAIN_ADVANCE(model, boris)            \
    COMPENSATED_ADVANCE(model, implicit_midpoint) COMPENSATED_ADVANCE(model, gauss_legendre4)
PLAIN_ADVANCES(linear)
PLAIN_ADVANCES(spherical)

#define DIVERGED(xn, yn, vxn, vyn) (!((xn) * (xn) + (yn) * (yn) <= bound2) || !(fabs(vxn) + fabs(vyn) < 1.0e300))

#define DEFINE_LOOPS(model, scheme)                                                                           \
    int fb_##model##_##scheme(const double *state0, const double *p, double h, int64_t n_steps,              \
                              int64_t stride, double *out, double radius_bound, int64_t *steps_done) {       \
        consts k = make_consts(p);                                                                            \
        scheme##_setup(&k, h);                                                                                \
        const double bound2 = radius_bound * radius_bound;                                                    \
        double x = state0[0], y = state0[1], vx = state0[2], vy = state0[3];                                  \
        double comp[4] = {0.0, 0.0, 0.0, 0.0}; /* the compensated sum's carries (COMPENSATED_ADVANCE) */       \
        out[0] = x; out[1] = y; out[2] = vx; out[3] = vy;                                                     \
        int64_t done = 0;                                                                                     \
        for (int64_t row = 1; row <= n_steps / stride; row++) {                                               \
            for (int64_t j = 0; j < stride; j++) {                                                            \
                double xn = x, yn = y, vxn = vx, vyn = vy;                                                    \
                model##_##scheme##_advance(&k, h, comp, &xn, &yn, &vxn, &vyn);                                         \
                if (DIVERGED(xn, yn, vxn, vyn)) { *steps_done = done; return 1; }                             \
                done++;                                                                                       \
                x = xn; y = yn; vx = vxn; vy = vyn;                                                           \
            }                                                                                                 \
            out[4 * row] = x; out[4 * row + 1] = y; out[4 * row + 2] = vx; out[4 * row + 3] = vy;             \
        }                                                                                                     \
        *steps_done = done;                                                                                   \
        return 0;                                                                                             \
    }                                                                                                         \
    int fb_##model##_##scheme##_monitor(const double *state0, const double *p, double h, int64_t n_steps,    \
                                        int64_t stride, double *out, double radius_bound, int64_t *steps_done,\
                                        double *turning, int64_t n_turning_max, int64_t *n_turning,          \
                                        double *max_rel_out, double *slope_out) {                            \
        consts k = make_consts(p);                                                                            \
        scheme##_setup(&k, h);                                                                                \
        const double bound2 = radius_bound * radius_bound;                                                    \
        double x = state0[0], y = state0[1], vx = state0[2], vy = state0[3];                                  \
        double comp[4] = {0.0, 0.0, 0.0, 0.0}; /* the compensated sum's carries (COMPENSATED_ADVANCE) */       \
        out[0] = x; out[1] = y; out[2] = vx; out[3] = vy;                                                     \
        const double energy0 = model##_energy(&k, x, y, vx, vy);                                              \
        const double swing = energy0 - model##_energy(&k, 0.0, 0.0, 0.0, 0.0);                               \
        const double energy_scale = swing > 0.0 ? swing : (energy0 != 0.0 ? fabs(energy0) : 1.0);             \
        double max_rel = 0.0, count = 0.0, mean_t = 0.0, mean_e = 0.0, co_te = 0.0, var_t = 0.0;              \
        double radial = x * vx + y * vy;                                                                      \
        int64_t done = 0, found = 0, i = 0;                                                                   \
        int status = 0;                                                                                       \
        for (int64_t row = 1; row <= n_steps / stride && !status; row++) {                                    \
            for (int64_t j = 0; j < stride; j++) {                                                            \
                double xn = x, yn = y, vxn = vx, vyn = vy;                                                    \
                model##_##scheme##_advance(&k, h, comp, &xn, &yn, &vxn, &vyn);                                         \
                if (DIVERGED(xn, yn, vxn, vyn)) { status = 1; break; }                                        \
                i++;                                                                                          \
                done = i;                                                                                     \
                double t = i * h;                                                                             \
                double rel = (model##_energy(&k, xn, yn, vxn, vyn) - energy0) / energy_scale;                 \
                if (fabs(rel) > max_rel) max_rel = fabs(rel);                                                 \
                count += 1.0;                                                                                 \
                double dt = t - mean_t;                                                                       \
                mean_t += dt / count;                                                                         \
                mean_e += (rel - mean_e) / count;                                                             \
                co_te += dt * (rel - mean_e);                                                                 \
                var_t += dt * (t - mean_t);                                                                   \
                double radial_new = xn * vxn + yn * vyn;                                                      \
                if (radial > 0.0 && radial_new <= 0.0 && found < n_turning_max) {                            \
                    double theta, tx, ty;                                                                     \
                    turning_point(x, y, vx, vy, xn, yn, vxn, vyn, h, radial, radial_new, &theta, &tx, &ty);  \
                    turning[3 * found] = (i - 1 + theta) * h;                                                 \
                    turning[3 * found + 1] = tx;                                                              \
                    turning[3 * found + 2] = ty;                                                              \
                    found++;                                                                                  \
                }                                                                                             \
                radial = radial_new;                                                                          \
                x = xn; y = yn; vx = vxn; vy = vyn;                                                           \
            }                                                                                                 \
            if (!status) { out[4 * row] = x; out[4 * row + 1] = y; out[4 * row + 2] = vx; out[4 * row + 3] = vy; } \
        }                                                                                                     \
        *steps_done = done;                                                                                   \
        *n_turning = found;                                                                                   \
        *max_rel_out = max_rel;                                                                               \
        *slope_out = var_t > 0.0 ? co_te / var_t : 0.0;                                                       \
        return status;                                                                                        \
    }

DEFINE_LOOPS(linear, explicit_euler)
DEFINE_LOOPS(linear, symplectic_euler)
DEFINE_LOOPS(linear, rk4)
DEFINE_LOOPS(linear, heun3)
DEFINE_LOOPS(linear, nystrom4)
DEFINE_LOOPS(linear, verlet)
DEFINE_LOOPS(linear, yoshida4)
DEFINE_LOOPS(linear, composition6)
DEFINE_LOOPS(linear, boris)
DEFINE_LOOPS(linear, implicit_midpoint)
DEFINE_LOOPS(linear, gauss_legendre4)
DEFINE_LOOPS(spherical, explicit_euler)
DEFINE_LOOPS(spherical, symplectic_euler)
DEFINE_LOOPS(spherical, rk4)
DEFINE_LOOPS(spherical, heun3)
DEFINE_LOOPS(spherical, nystrom4)
DEFINE_LOOPS(spherical, verlet)
DEFINE_LOOPS(spherical, yoshida4)
DEFINE_LOOPS(spherical, composition6)
DEFINE_LOOPS(spherical, boris)
DEFINE_LOOPS(spherical, implicit_midpoint)
DEFINE_LOOPS(spherical, gauss_legendre4)

/* ---- composition8 and composition10 (integrators/methods/composition8.py, composition10.py): 15 and 35
 * sub-steps taken as consecutive sequences of at most SEQUENCE_SUB_STEPS (integrators/composition.py), each in
 * the canonical variables with its own merged rotations (integrators/methods/verlet.py verlet_sequences: the
 * rotations of sequence j stored from row first + j) ---- */

#define SEQUENCE_SUB_STEPS 9

/* McLachlan's 15-stage order-8 weights and Sofroniou & Spaletta's s35odr10, digits as in the Python sources */
static const double COMPOSITION8[15] = {
    0.74167036435061295344822780, -0.40910082580003159399730010, 0.19075471029623837995387626,
    -0.57386247111608226665638773, 0.29906418130365592384446354, 0.33462491824529818378495798,
    0.31529309239676659663205666, -0.79688793935291635401978884, 0.31529309239676659663205666,
    0.33462491824529818378495798, 0.29906418130365592384446354, -0.57386247111608226665638773,
    0.19075471029623837995387626, -0.40910082580003159399730010, 0.74167036435061295344822780};
static const double COMPOSITION10[35] = {
    0.078795722521686419263907679337684, 0.31309610341510852776481247192647,
    0.027918383235078066109520273275299, -0.22959284159390709415121339679655,
    0.13096206107716486317465685927961, -0.26973340565451071434460973222411,
    0.074973343155891435666137105641410, 0.11199342399981020488957508073640,
    0.36613344954622675119314812353150, -0.39910563013603589787862981058340,
    0.10308739852747107731580277001372, 0.41143087395589023782070411897608,
    -0.0048663605831352617621956593099771, -0.39203335370863990644808193642610,
    0.051942502962449647037182904015976, 0.050665090759924496335874344156866,
    0.049674370639729879054568800279461, 0.049317735759594537917680008339338,
    0.049674370639729879054568800279461, 0.050665090759924496335874344156866,
    0.051942502962449647037182904015976, -0.39203335370863990644808193642610,
    -0.0048663605831352617621956593099771, 0.41143087395589023782070411897608,
    0.10308739852747107731580277001372, -0.39910563013603589787862981058340,
    0.36613344954622675119314812353150, 0.11199342399981020488957508073640,
    0.074973343155891435666137105641410, -0.26973340565451071434460973222411,
    0.13096206107716486317465685927961, -0.22959284159390709415121339679655,
    0.027918383235078066109520273275299, 0.31309610341510852776481247192647,
    0.078795722521686419263907679337684};

static inline int sequence_length(int first, int n) { return n - first < SEQUENCE_SUB_STEPS ? n - first : SEQUENCE_SUB_STEPS; }

static void sequences_setup(consts *k, double h, const double *gamma, int n) {
    for (int first = 0, j = 0; first < n; first += SEQUENCE_SUB_STEPS, j++)
        sequence_setup(k, h, gamma + first, first, first + j, sequence_length(first, n));
}
static void composition8_setup(consts *k, double h) { sequences_setup(k, h, COMPOSITION8, 15); }
static void composition10_setup(consts *k, double h) { sequences_setup(k, h, COMPOSITION10, 35); }

#define DEFINE_SEQUENCES_STEP(model, scheme, n)                                                               \
    static inline void model##_##scheme##_step(const consts *k, double h, double *x, double *y, double *vx,  \
                                               double *vy) {                                                 \
        (void)h;                                                                                              \
        for (int first = 0, j = 0; first < n; first += SEQUENCE_SUB_STEPS, j++)                              \
            model##_sequence(k, first, first + j, sequence_length(first, n), x, y, vx, vy);                   \
    }                                                                                                         \
    PLAIN_ADVANCE(model, scheme)                                                                              \
    DEFINE_LOOPS(model, scheme)
DEFINE_SEQUENCES_STEP(linear, composition8, 15)
DEFINE_SEQUENCES_STEP(linear, composition10, 35)
DEFINE_SEQUENCES_STEP(spherical, composition8, 15)
DEFINE_SEQUENCES_STEP(spherical, composition10, 35)

/* ---- gbs4 (integrators/methods/gbs4.py, integrators/extrapolation.py FixedOrderExtrapolation): per step the
 * smoothed explicit midpoint lines of 2 and 4 substeps from one shared f(z0) (build_midpoint_line), combined
 * with the Lagrange weights c = (-1/3, 4/3) of the harmonic sequence (extrapolation_weights) as the numba step
 * sums them: from 0.0, in line order; the new state in place (no increment, no compensation) ---- */
#define GBS4_WEIGHT_1 (-0.3333333333333333) /* float(Fraction(-1, 3)) */
#define GBS4_WEIGHT_2 1.3333333333333333    /* float(Fraction(4, 3)) */
#define gbs4_setup no_setup

#define DEFINE_GBS4_STEP(model)                                                                               \
    static inline void model##_midpoint_line(const consts *k, double x, double y, double vx, double vy,      \
                                             double ax0, double ay0, double big_h, int n, double *t) {       \
        double h = big_h / n, two_h = 2.0 * h, ax, ay;                                                        \
        double px = x, py = y, pvx = vx, pvy = vy;                                                            \
        double cx = x + h * vx, cy = y + h * vy, cvx = vx + h * ax0, cvy = vy + h * ay0;                      \
        model##_acceleration(k, cx, cy, cvx, cvy, &ax, &ay);                                                  \
        for (int m = 0; m < n - 1; m++) {                                                                     \
            double nx = px + two_h * cvx, ny = py + two_h * cvy, nvx = pvx + two_h * ax, nvy = pvy + two_h * ay;\
            px = cx; py = cy; pvx = cvx; pvy = cvy;                                                           \
            cx = nx; cy = ny; cvx = nvx; cvy = nvy;                                                           \
            model##_acceleration(k, cx, cy, cvx, cvy, &ax, &ay);                                              \
        }                                                                                                     \
        t[0] = 0.5 * (px + cx + h * cvx);                                                                     \
        t[1] = 0.5 * (py + cy + h * cvy);                                                                     \
        t[2] = 0.5 * (pvx + cvx + h * ax);                                                                    \
        t[3] = 0.5 * (pvy + cvy + h * ay);                                                                    \
    }                                                                                                         \
    static inline void model##_gbs4_step(const consts *k, double h, double *x, double *y, double *vx,        \
                                         double *vy) {                                                       \
        double ax0, ay0, t1[4], t2[4];                                                                        \
        model##_acceleration(k, *x, *y, *vx, *vy, &ax0, &ay0);                                                \
        model##_midpoint_line(k, *x, *y, *vx, *vy, ax0, ay0, h, 2, t1);                                       \
        model##_midpoint_line(k, *x, *y, *vx, *vy, ax0, ay0, h, 4, t2);                                       \
        double sx = 0.0, sy = 0.0, svx = 0.0, svy = 0.0;                                                      \
        sx += GBS4_WEIGHT_1 * t1[0]; sy += GBS4_WEIGHT_1 * t1[1];                                             \
        svx += GBS4_WEIGHT_1 * t1[2]; svy += GBS4_WEIGHT_1 * t1[3];                                           \
        sx += GBS4_WEIGHT_2 * t2[0]; sy += GBS4_WEIGHT_2 * t2[1];                                             \
        svx += GBS4_WEIGHT_2 * t2[2]; svy += GBS4_WEIGHT_2 * t2[3];                                           \
        *x = sx; *y = sy; *vx = svx; *vy = svy;                                                               \
    }
DEFINE_GBS4_STEP(linear)
DEFINE_GBS4_STEP(spherical)
PLAIN_ADVANCE(linear, gbs4)
PLAIN_ADVANCE(spherical, gbs4)
DEFINE_LOOPS(linear, gbs4)
DEFINE_LOOPS(spherical, gbs4)
