/* C transcriptions of two stackx solvers, the yardstick for the speed benchmark (gcc -O2, one thread).
 *
 * Written from the solvers' stage lists, not generated from stackx: the lab step (solver "pgs": gravity,
 * velocity passes clamping each visit, positions, the lab's position correction) and the warm-started
 * accumulated-impulse step (solver "warm-start": gravity, prepare contacts, warm start, velocity
 * iterations clamping each contact's sum, positions, correction). Arrays are (rows, n) row-major; rows are
 * independent variants stepped one after another. The monitors stackx updates after every step are not
 * part of the algorithm and are left out, which only makes the comparison harder for stackx.
 *
 * Python's max(a, b) keeps a unless b > a; py_max does the same, so that every result matches the Python
 * and numba code bit for bit (compiled with -ffp-contract=off: no fused multiply-add).
 */

#include <stdint.h>

static double py_max(double a, double b) { return b > a ? b : a; }

/* The lab's correct(): the move of object 1 along -n (*down) and of object 2 along +n (*up). */
static void correct(double depth, double slop, double percent, double inv1, double inv2, double *down, double *up)
{
    double total = inv1 + inv2;
    if (total == 0.0) {
        *down = 0.0;
        *up = 0.0;
        return;
    }
    double c = py_max(depth - slop, 0.0) / total * percent;
    *down = c * inv1;
    *up = c * inv2;
}

static void gravity(long n, double *v, double g, double dt)
{
    for (long i = 0; i < n; i++)
        v[i] += g * dt;
}

static void integrate_positions(long n, double *y, const double *v, double dt)
{
    for (long i = 0; i < n; i++)
        y[i] += v[i] * dt;
}

static void correct_positions(long n, double *y, const double *inv, const double *half, double slop, double percent)
{
    double down, up;
    correct(half[0] - y[0], slop, percent, 0.0, inv[0], &down, &up);
    y[0] += up;
    for (long i = 0; i < n - 1; i++) {
        correct((half[i] + half[i + 1]) - (y[i + 1] - y[i]), slop, percent, inv[i], inv[i + 1], &down, &up);
        y[i] -= down;
        y[i + 1] += up;
    }
}

static void velocity_pass(long n, const double *y, double *v, const double *inv, const double *half)
{
    if (half[0] - y[0] > 0.0 && v[0] < 0.0 && inv[0] > 0.0)
        v[0] = 0.0;
    for (long i = 0; i < n - 1; i++) {
        double depth = (half[i] + half[i + 1]) - (y[i + 1] - y[i]);
        double rv = v[i + 1] - v[i];
        double total = inv[i] + inv[i + 1];
        if (depth > 0.0 && rv < 0.0 && total > 0.0) {
            double j = -rv / total;
            v[i] -= j * inv[i];
            v[i + 1] += j * inv[i + 1];
        }
    }
}

void lab_advance(long rows, long n, double *y, double *v, const double *inv, const double *half, const double *g,
                 const double *dt, const int64_t *iterations, const unsigned char *corrects, const double *slop,
                 const double *percent, long steps)
{
    for (long b = 0; b < rows; b++) {
        double *yb = y + b * n, *vb = v + b * n;
        const double *ib = inv + b * n, *hb = half + b * n;
        for (long s = 0; s < steps; s++) {
            gravity(n, vb, g[b], dt[b]);
            for (long k = 0; k < iterations[b]; k++)
                velocity_pass(n, yb, vb, ib, hb);
            integrate_positions(n, yb, vb, dt[b]);
            if (corrects[b])
                correct_positions(n, yb, ib, hb, slop[b], percent[b]);
        }
    }
}

/* Contact k: k = 0 is the floor under box 0, k >= 1 the pair of box k-1 (below) and box k (above). */

static void push(double *x, const double *inv, long k, double p)
{
    if (k > 0)
        x[k - 1] -= p * inv[k - 1];
    x[k] += p * inv[k];
}

/* Which contacts take part (overlapping, or within `speculative` of touching) and the slowest relative
 * velocity each accepts: no approach when touching (warm-start uses no bias), closing the gap within dt
 * when apart. A contact that sits the step out forgets its impulse. */
static void prepare(long n, const double *y, const double *inv, const double *half, double dt, double speculative,
                    double *impulse, double *mass, double *target)
{
    for (long k = 0; k < n; k++) {
        double d = k == 0 ? half[0] - y[0] : (half[k - 1] + half[k]) - (y[k] - y[k - 1]);
        double total = k == 0 ? inv[0] : inv[k - 1] + inv[k];
        if (d > -speculative && total > 0.0) {
            mass[k] = 1.0 / total;
            target[k] = d > 0.0 ? 0.0 : d / dt;
        } else {
            mass[k] = 0.0;
            target[k] = 0.0;
            impulse[k] = 0.0;
        }
    }
}

static void warm_start(long n, double *v, const double *inv, const double *impulse)
{
    for (long k = 0; k < n; k++)
        if (impulse[k] != 0.0)
            push(v, inv, k, impulse[k]);
}

static void velocity_iteration(long n, double *v, const double *inv, double *impulse, const double *mass,
                               const double *target)
{
    for (long k = 0; k < n; k++) {
        if (mass[k] > 0.0) {
            double rv = k == 0 ? v[0] : v[k] - v[k - 1];
            double total = py_max(impulse[k] + mass[k] * (target[k] - rv), 0.0);
            push(v, inv, k, total - impulse[k]);
            impulse[k] = total;
        }
    }
}

/* work: 2 * n doubles of scratch (per-contact mass and target). impulse carries over between calls. */
void warm_start_advance(long rows, long n, double *y, double *v, const double *inv, const double *half,
                        const double *g, const double *dt, const int64_t *iterations, const unsigned char *corrects,
                        const double *slop, const double *percent, const double *speculative, double *impulse,
                        double *work, long steps)
{
    double *mass = work, *target = work + n;
    for (long b = 0; b < rows; b++) {
        double *yb = y + b * n, *vb = v + b * n, *pb = impulse + b * n;
        const double *ib = inv + b * n, *hb = half + b * n;
        for (long s = 0; s < steps; s++) {
            gravity(n, vb, g[b], dt[b]);
            prepare(n, yb, ib, hb, dt[b], speculative[b], pb, mass, target);
            warm_start(n, vb, ib, pb);
            for (long k = 0; k < iterations[b]; k++)
                velocity_iteration(n, vb, ib, pb, mass, target);
            integrate_positions(n, yb, vb, dt[b]);
            if (corrects[b])
                correct_positions(n, yb, ib, hb, slop[b], percent[b]);
        }
    }
}
