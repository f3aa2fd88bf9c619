/* C transcriptions of three stackx solvers, the yardstick for the speed benchmark (gcc -O2, one thread).
 *
 * Written from the solvers' stage lists, not generated from stackx: the lab step (solver "pgs": gravity,
 * velocity passes clamping each visit, positions, the lab's position correction), the warm-started
 * accumulated-impulse step (solver "warm-start": gravity, prepare contacts, warm start, velocity
 * iterations clamping each contact's sum, positions, correction) and the exact velocity solve (solver
 * "exact": gravity, prepare contacts, pool-adjacent-violators solve of the column, positions, correction).
 * Arrays are (rows, n) row-major; rows are independent variants stepped one after another. The monitors
 * stackx updates after every step are not part of the algorithms and are left out, which only makes the
 * comparison harder for stackx.
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

/* Apply the impulses carried from the last step, or forget them (carry = 0). */
static void warm_start(long n, double *v, const double *inv, double *impulse, int carry)
{
    for (long k = 0; k < n; k++) {
        if (!carry)
            impulse[k] = 0.0;
        else if (impulse[k] != 0.0)
            push(v, inv, k, impulse[k]);
    }
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
                        const double *g, const double *dt, const int64_t *iterations, const unsigned char *carry,
                        const unsigned char *corrects, const double *slop, const double *percent,
                        const double *speculative, double *impulse, double *work, long steps)
{
    double *mass = work, *target = work + n;
    for (long b = 0; b < rows; b++) {
        double *yb = y + b * n, *vb = v + b * n, *pb = impulse + b * n;
        const double *ib = inv + b * n, *hb = half + b * n;
        for (long s = 0; s < steps; s++) {
            gravity(n, vb, g[b], dt[b]);
            prepare(n, yb, ib, hb, dt[b], speculative[b], pb, mass, target);
            warm_start(n, vb, ib, pb, carry[b]);
            for (long k = 0; k < iterations[b]; k++)
                velocity_iteration(n, vb, ib, pb, mass, target);
            integrate_positions(n, yb, vb, dt[b]);
            if (corrects[b])
                correct_positions(n, yb, ib, hb, slop[b], percent[b]);
        }
    }
}

/* The exact solve of one column's velocity problem (isotonic regression by pool-adjacent-violators), then
 * each contact's impulse from the momentum changes. Scratch: `work` holds 7 n + 7 doubles, `iwork` 2 n + 2
 * integers. */
static void column_impulses(long n, const double *v, const double *u, const double *inv, const double *mass,
                            const int64_t *block, const int64_t *first, double *impulse)
{
    for (long k = 0; k < n; k++)
        impulse[k] = 0.0;
    long i = n - 1;
    while (i >= 0) {
        if (inv[i] == 0.0) {
            i -= 1;
            continue;
        }
        long b = i, a = i;
        while (a > 0 && inv[a - 1] > 0.0 && mass[a] > 0.0 && block[a - 1] == block[a])
            a -= 1;
        int top_pinned = b + 1 < n && mass[b + 1] > 0.0 && block[b + 1] == block[b];
        int bottom_pinned = mass[a] > 0.0 && (a == 0 ? first[block[a]] == -1 : block[a - 1] == block[a]);
        double total = 0.0, lowest = 0.0;
        for (long k = b; k > a - 1; k--) {
            total += (v[k] - u[k]) / inv[k];
            impulse[k] = total;
            lowest = total < lowest ? total : lowest;
        }
        double carried = 0.0;
        if (top_pinned && !bottom_pinned)
            carried = -total;
        else if (top_pinned)
            carried = -lowest;
        if (top_pinned)
            impulse[b + 1] = carried;
        for (long k = a; k < b + 1; k++)
            impulse[k] += carried;
        if (!bottom_pinned)
            impulse[a] = 0.0;
        i = a - 1;
    }
}

static void solve_column(long n, double *v, const double *inv, const double *mass, const double *target,
                         double *impulse, double *work, int64_t *iwork)
{
    double *u = work, *shift = work + n, *weight = work + 2 * n, *momentum = work + 3 * n + 1;
    double *pins = work + 4 * n + 2, *pinned = work + 5 * n + 3, *value = work + 6 * n + 4;
    int64_t *first = iwork, *block = iwork + n + 2;
    for (long i = 0; i < n; i++)
        u[i] = v[i];
    long top = -1, bottom = 0;
    double running = 0.0;
    for (long i = 0; i < n; i++) {
        if (mass[i] > 0.0) {
            running += target[i];
            if (i == 0) {
                top += 1;
                first[top] = -1;
                weight[top] = 0.0, momentum[top] = 0.0, pins[top] = 1.0, pinned[top] = 0.0, value[top] = 0.0;
            }
        } else {
            running = 0.0;
            bottom = top + 1;
        }
        shift[i] = running;
        double s = u[i] - running;
        top += 1;
        first[top] = i;
        if (inv[i] > 0.0)
            weight[top] = 1.0 / inv[i], momentum[top] = s / inv[i], pins[top] = 0.0, pinned[top] = 0.0;
        else
            weight[top] = 0.0, momentum[top] = 0.0, pins[top] = 1.0, pinned[top] = s;
        value[top] = s;
        while (top > bottom && value[top - 1] > value[top]) {
            weight[top - 1] += weight[top];
            momentum[top - 1] += momentum[top];
            pins[top - 1] += pins[top];
            pinned[top - 1] += pinned[top];
            top -= 1;
            value[top] = pins[top] > 0.0 ? pinned[top] / pins[top] : momentum[top] / weight[top];
        }
    }
    first[top + 1] = n;
    for (long b = 0; b < top + 1; b++) {
        for (long i = first[b] > 0 ? first[b] : 0; i < first[b + 1]; i++) {
            block[i] = b;
            if (inv[i] > 0.0 && first[b + 1] - first[b] > 1)
                v[i] = value[b] + shift[i];
        }
    }
    column_impulses(n, v, u, inv, mass, block, first, impulse);
}

/* work: 10 n + 7 doubles, iwork: 2 n + 2 integers of scratch. */
void exact_advance(long rows, long n, double *y, double *v, const double *inv, const double *half, const double *g,
                   const double *dt, const unsigned char *corrects, const double *slop, const double *percent,
                   const double *speculative, double *work, int64_t *iwork, long steps)
{
    double *mass = work, *target = work + n, *impulse = work + 2 * n, *scratch = work + 3 * n;
    for (long b = 0; b < rows; b++) {
        double *yb = y + b * n, *vb = v + b * n;
        const double *ib = inv + b * n, *hb = half + b * n;
        for (long k = 0; k < n; k++)
            impulse[k] = 0.0;
        for (long s = 0; s < steps; s++) {
            gravity(n, vb, g[b], dt[b]);
            prepare(n, yb, ib, hb, dt[b], speculative[b], impulse, mass, target);
            solve_column(n, vb, ib, mass, target, impulse, scratch, iwork);
            integrate_positions(n, yb, vb, dt[b]);
            if (corrects[b])
                correct_positions(n, yb, ib, hb, slop[b], percent[b]);
        }
    }
}
