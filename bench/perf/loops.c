/* Plain scalar C loops of the suite's fixed-step schemes: the hardware reference of `foucault-bench perf`.
 *
 * The model arithmetic is the suite's, written out literally (models/linear.py, models/spherical.py,
 * models/base.py): every expression keeps the operand order of its Python twin, including the multiplications
 * by the zero velocities and zero rotation components that the one-source models carry, so that a C loop and
 * the numba kernel compute the same states (bitwise: neither contracts a*b+c into an FMA). The schemes
 * (integrators/{explicit_euler,symplectic_euler,rk4,verlet}.py) and the loop (integrators/fixed_step.py) are
 * written as a C programmer writes them for speed:
 *   - every loop invariant computed once before the loop: the parameters read into local scalars, the plane
 *     Verlet rotation's cosine and sine, and the sphere Verlet's rotation by -|w| h/2 as a 3x3 matrix
 *     (R = cos a I + sin a [n]x + (1 - cos a) n n^T; 9 multiplications and 6 additions per rotation instead of
 *     Rodrigues' vector form), which the numba step computes the same way (integrators/verlet.py);
 *   - four scalar doubles of state, two nested loops (output rows, steps per row: no modulo per step), the
 *     divergence test after every step, the state written to `out` once per row;
 *   - sqrt, not pow(x, 0.5).
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

typedef struct {
    double g, length, k2, wx, wy, wz, c;  /* models/parameters.py PARAMETER_VECTOR_NAMES */
    double cos_half, sin_half;            /* plane Verlet: rotation by -a h/2 about z */
    double rot[9];                        /* sphere Verlet: rotation by -|w| h/2 about w, row-major */
} consts;

static consts make_consts(const double *p, double h) {
    consts k;
    k.g = p[0]; k.length = p[1]; k.k2 = p[2]; k.wx = p[3]; k.wy = p[4]; k.wz = p[5]; k.c = p[6];
    k.cos_half = cos(-0.5 * k.wz * h);
    k.sin_half = sin(-0.5 * k.wz * h);
    /* integrators/verlet.py _half_step_rotation: R = cos a I + sin a [n]x + (1 - cos a) n n^T */
    double rate = sqrt(k.wx * k.wx + k.wy * k.wy + k.wz * k.wz);
    if (rate == 0.0) {
        const double identity[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
        for (int i = 0; i < 9; i++) k.rot[i] = identity[i];
        return k;
    }
    double nx = k.wx / rate, ny = k.wy / rate, nz = k.wz / rate;
    double angle = -0.5 * rate * h;
    double cos_a = cos(angle), sin_a = sin(angle), u = 1.0 - cos_a;
    k.rot[0] = cos_a + u * nx * nx; k.rot[1] = u * nx * ny - sin_a * nz; k.rot[2] = u * nx * nz + sin_a * ny;
    k.rot[3] = u * ny * nx + sin_a * nz; k.rot[4] = cos_a + u * ny * ny; k.rot[5] = u * ny * nz - sin_a * nx;
    k.rot[6] = u * nz * nx - sin_a * ny; k.rot[7] = u * nz * ny + sin_a * nx; k.rot[8] = cos_a + u * nz * nz;
    return k;
}

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

/* ---- schemes: one step (x, y, vx, vy) -> next, in place ---- */

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
    static inline void model##_rk4_step(const consts *k, double h, double *px, double *py, double *pvx,      \
                                        double *pvy) {                                                       \
        double x = *px, y = *py, vx = *pvx, vy = *pvy, half = 0.5 * h;                                        \
        double k1ax, k1ay, k2ax, k2ay, k3ax, k3ay, k4ax, k4ay;                                                \
        model##_acceleration(k, x, y, vx, vy, &k1ax, &k1ay);                                                  \
        double x2 = x + half * vx, y2 = y + half * vy, vx2 = vx + half * k1ax, vy2 = vy + half * k1ay;        \
        model##_acceleration(k, x2, y2, vx2, vy2, &k2ax, &k2ay);                                              \
        double x3 = x + half * vx2, y3 = y + half * vy2, vx3 = vx + half * k2ax, vy3 = vy + half * k2ay;      \
        model##_acceleration(k, x3, y3, vx3, vy3, &k3ax, &k3ay);                                              \
        double x4 = x + h * vx3, y4 = y + h * vy3, vx4 = vx + h * k3ax, vy4 = vy + h * k3ay;                  \
        model##_acceleration(k, x4, y4, vx4, vy4, &k4ax, &k4ay);                                              \
        double sixth = h / 6.0;                                                                               \
        *px = x + sixth * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4);                                                 \
        *py = y + sixth * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4);                                                 \
        *pvx = vx + sixth * (k1ax + 2.0 * k2ax + 2.0 * k3ax + k4ax);                                          \
        *pvy = vy + sixth * (k1ay + 2.0 * k2ay + 2.0 * k3ay + k4ay);                                          \
    }
DEFINE_RUNGE_KUTTA_STEPS(linear)
DEFINE_RUNGE_KUTTA_STEPS(spherical)

/* integrators/verlet.py _plane_step (Hamiltonian planar model) */
static inline void linear_verlet_step(const consts *k, double h, double *px_, double *py_, double *pvx,
                                      double *pvy) {
    double a = k->wz, c = k->cos_half, s = k->sin_half, x = *px_, y = *py_, t, fx, fy, fz;
    double px = *pvx - a * y, py = *pvy + a * x;
    t = c * x - s * y; y = s * x + c * y; x = t;
    t = c * px - s * py; py = s * px + c * py; px = t;
    linear_kick(k, x, y, 0.0, &fx, &fy, &fz);
    px += 0.5 * h * fx;
    py += 0.5 * h * fy;
    x += h * px;
    y += h * py;
    linear_kick(k, x, y, 0.0, &fx, &fy, &fz);
    px = px + 0.5 * h * fx;
    py = py + 0.5 * h * fy;
    t = c * x - s * y; y = s * x + c * y; x = t;
    t = c * px - s * py; py = s * px + c * py; px = t;
    *px_ = x;
    *py_ = y;
    *pvx = px + a * y;
    *pvy = py - a * x;
}

/* integrators/verlet.py _rotate: the precomputed 3x3 matrix applied (9 multiplications, 6 additions) */
static inline void rotate(const consts *k, double *vx, double *vy, double *vz) {
    const double *r = k->rot;
    double rx = r[0] * *vx + r[1] * *vy + r[2] * *vz;
    double ry = r[3] * *vx + r[4] * *vy + r[5] * *vz;
    double rz = r[6] * *vx + r[7] * *vy + r[8] * *vz;
    *vx = rx;
    *vy = ry;
    *vz = rz;
}

/* integrators/verlet.py _sphere_step (RATTLE between two exact rotations) */
static inline void spherical_verlet_step(const consts *k, double h, double *px_, double *py_, double *pvx,
                                         double *pvy) {
    double wx = k->wx, wy = k->wy, wz = k->wz, length = k->length, l2 = length * length;
    double x = *px_, y = *py_, vx = *pvx, vy = *pvy, fx, fy, fz;
    double z = -sqrt(l2 - x * x - y * y);
    double vz = -(x * vx + y * vy) / z;
    double px = vx + wy * z - wz * y, py = vy + wz * x - wx * z, pz = vz + wx * y - wy * x;
    rotate(k, &x, &y, &z);
    rotate(k, &px, &py, &pz);
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
    rotate(k, &xn, &yn, &zn);
    rotate(k, &px, &py, &pz);
    *px_ = xn;
    *py_ = yn;
    *pvx = px - (wy * zn - wz * yn);
    *pvy = py - (wz * xn - wx * zn);
}

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

#define DIVERGED(xn, yn, vxn, vyn) (!((xn) * (xn) + (yn) * (yn) <= bound2) || !(fabs(vxn) + fabs(vyn) < 1.0e300))

#define DEFINE_LOOPS(model, scheme)                                                                           \
    int fb_##model##_##scheme(const double *state0, const double *p, double h, int64_t n_steps,              \
                              int64_t stride, double *out, double radius_bound, int64_t *steps_done) {       \
        const consts k = make_consts(p, h);                                                                   \
        const double bound2 = radius_bound * radius_bound;                                                    \
        double x = state0[0], y = state0[1], vx = state0[2], vy = state0[3];                                  \
        out[0] = x; out[1] = y; out[2] = vx; out[3] = vy;                                                     \
        int64_t done = 0;                                                                                     \
        for (int64_t row = 1; row <= n_steps / stride; row++) {                                               \
            for (int64_t j = 0; j < stride; j++) {                                                            \
                double xn = x, yn = y, vxn = vx, vyn = vy;                                                    \
                model##_##scheme##_step(&k, h, &xn, &yn, &vxn, &vyn);                                         \
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
        const consts k = make_consts(p, h);                                                                   \
        const double bound2 = radius_bound * radius_bound;                                                    \
        double x = state0[0], y = state0[1], vx = state0[2], vy = state0[3];                                  \
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
                model##_##scheme##_step(&k, h, &xn, &yn, &vxn, &vyn);                                         \
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
DEFINE_LOOPS(linear, verlet)
DEFINE_LOOPS(spherical, explicit_euler)
DEFINE_LOOPS(spherical, symplectic_euler)
DEFINE_LOOPS(spherical, rk4)
DEFINE_LOOPS(spherical, verlet)
