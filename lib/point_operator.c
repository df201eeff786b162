/*
 * point_operator.c - the Belkin-Sun-Wang operator of a weighted point set:
 * the matrix B of laplacian.c (see there for the formulas) with given
 * masses A_p in place of a mesh's vertex areas. HKS-simp builds it on its
 * samples, whose masses are the areas they stand for.
 *
 * The loops are laplacian.c's, in the same order (grid cells, then points
 * by cell), so for the vertices and vertex areas of a mesh the result is
 * bit for bit phks_operator_build's (test_simplify checks it); laplacian.c
 * could become a call of this one.
 */
#include "simp.h"

#define ROW_BATCHES 16

typedef struct {
    const phks_grid *grid;
    const double *xyz;
    double scale;
    double radius2;   /* squared cut-off radius */
    double inv4h;     /* 1 / 4h */
    const double *area;
    size_t *row_start;
    uint32_t *col;
    double *val;      /* on the fill pass: A_p W(w,p) */
    double *density;  /* sum_p A_p W(w,p), p = w included */
    bool fill;
} build_ctx;

static void scan_row(const build_ctx *b, size_t w)
{
    const phks_grid *g = b->grid;
    double p[3];
    size_t c[3];
    for (int d = 0; d < 3; d++) {
        p[d] = b->xyz[3 * w + d] * b->scale;
        double x = floor((p[d] - g->origin[d]) / g->cell);
        c[d] = x < 0 ? 0 : x >= (double)g->dims[d] ? g->dims[d] - 1 : (size_t)x;
    }
    size_t count = 0, out = b->fill ? b->row_start[w] : 0;
    double density = 0;
    for (size_t z = c[2] ? c[2] - 1 : 0; z <= c[2] + 1 && z < g->dims[2]; z++)
        for (size_t y = c[1] ? c[1] - 1 : 0; y <= c[1] + 1 && y < g->dims[1]; y++)
            for (size_t x = c[0] ? c[0] - 1 : 0; x <= c[0] + 1 && x < g->dims[0]; x++) {
                size_t cell = (z * g->dims[1] + y) * g->dims[0] + x;
                for (size_t i = g->cell_start[cell]; i < g->cell_start[cell + 1]; i++) {
                    uint32_t q = g->points[i];
                    const double *r = b->xyz + 3 * (size_t)q;
                    double dx = r[0] * b->scale - p[0], dy = r[1] * b->scale - p[1],
                           dz = r[2] * b->scale - p[2];
                    double d2 = dx * dx + dy * dy + dz * dz;
                    if (d2 >= b->radius2 && q != w)
                        continue;
                    count++;
                    if (!b->fill)
                        continue;
                    double aw = b->area[q] * exp(-d2 * b->inv4h);
                    density += aw;
                    b->col[out] = q;
                    b->val[out] = aw;
                    out++;
                }
            }
    if (b->fill)
        b->density[w] = density;
    else
        b->row_start[w + 1] = count;
}

static void scan_rows(void *ctx, size_t begin, size_t end)
{
    for (size_t w = begin; w < end; w++)
        scan_row(ctx, w);
}

/* Turns the stored A_p W(w,p) into entries of B. */
static void finish_values(phks_operator_matrix *op, const double *area,
                          const double *gain, double c)
{
    double bound = 0;
    for (size_t w = 0; w < op->n; w++) {
        double diag = 0, off = 0;
        size_t self = op->row_start[w];
        for (size_t i = op->row_start[w]; i < op->row_start[w + 1]; i++) {
            uint32_t p = op->col[i];
            if (p == w) {
                self = i;
                continue;
            }
            double k = area[w] * op->val[i]; /* K_wp = A_w A_p W */
            if (gain)
                k *= sqrt(gain[w] * gain[p]);
            diag += k;
            op->val[i] = -c * k / sqrt(op->mass[w] * op->mass[p]);
            off += fabs(op->val[i]);
        }
        op->val[self] = c * diag / op->mass[w];
        bound = fmax(bound, op->val[self] + off);
    }
    op->norm_bound = bound;
}

phks_status phks_point_operator_build(const double *xyz, size_t n,
                                      double scale, const double *area,
                                      const double *gain,
                                      const phks_options *opt, double done,
                                      double span, phks_operator_matrix *op)
{
    memset(op, 0, sizeof *op);
    double h = opt->tau, radius = opt->cutoff * sqrt(4 * h);
    double *density = phks_malloc_array(n, sizeof *density);
    phks_grid grid = {0};
    phks_status st = PHKS_OK;
    op->n = n;
    op->row_start = phks_calloc(n + 1, sizeof *op->row_start);
    op->mass = phks_malloc_array(n, sizeof *op->mass);
    if (!density || !op->row_start || !op->mass) {
        st = phks_fail_oom("operator");
        goto done;
    }
    st = phks_grid_build(xyz, n, scale, radius, &grid);
    if (st != PHKS_OK)
        goto done;

    build_ctx b = {&grid, xyz, scale, radius * radius, 1 / (4 * h), area,
                   op->row_start, NULL, NULL, density, false};
    unsigned threads = phks_thread_count(opt);
    st = phks_run_batched(n, threads, scan_rows, &b, opt, PHKS_STAGE_OPERATOR,
                          done, 0.3 * span, ROW_BATCHES);
    if (st != PHKS_OK)
        goto done;
    for (size_t w = 0; w < n; w++)
        op->row_start[w + 1] += op->row_start[w];
    size_t nnz = op->row_start[n];
    op->col = phks_malloc_array(nnz, sizeof *op->col);
    op->val = phks_malloc_array(nnz, sizeof *op->val);
    if (!op->col || !op->val) {
        st = phks_fail_oom("operator matrix");
        goto done;
    }
    b.col = op->col;
    b.val = op->val;
    b.fill = true;
    st = phks_run_batched(n, threads, scan_rows, &b, opt, PHKS_STAGE_OPERATOR,
                          done + 0.3 * span, 0.7 * span, ROW_BATCHES);
    if (st != PHKS_OK)
        goto done;

    for (size_t w = 0; w < n; w++)
        op->mass[w] = opt->operator_kind == PHKS_OPERATOR_RANDOM_WALK
                          ? area[w] * density[w] / (4 * PHKS_PI * h)
                          : area[w];
    finish_values(op, area, gain, 1 / (4 * PHKS_PI * h * h));
    st = phks_progress(opt, PHKS_STAGE_OPERATOR, done + span);
done:
    phks_grid_release(&grid);
    phks_free(density);
    if (st != PHKS_OK)
        phks_operator_release(op);
    return st;
}
