/*
 * simp_extend.c - from the samples' eigenpairs back to every mesh vertex, by
 * the Nystrom formula (docs/method.md section 11). The eigen-equation of the
 * samples' operator, written at any point w with the samples p within the
 * cut-off, s_w = sum_p A_p W(w,p) and N_w = sum_p A_p W(w,p) phi(p):
 *
 *   literal operator:      phi(w) = N_w / (s_w - 4 pi h^2 lambda)
 *   random-walk operator:  phi(w) = N_w / (s_w (1 - h lambda))
 *
 * At a sample (whose own term, W = 1, is in both sums) this gives back
 * phi(p), so the extension interpolates the samples' eigenvectors; between
 * them it is the eigenfunction of the same kernel operator. The samples'
 * operator weighs the kernel between p and q by sqrt(g_p g_q) (the gains
 * of simp_sample.c), so the sums are taken with weights A_p W(w,p) sqrt(g_p),
 * and sqrt(g_w) at w is their kernel average s'_w / s_w:
 *
 *   literal:      phi(w) = N'_w / (s'_w - 4 pi h^2 lambda s_w / s'_w)
 *   random walk:  phi(w) = N'_w / (s'_w - h lambda s_w^2 / s'_w)
 *
 * with s_w = sum_p A_p W, s'_w = sum_p A_p W sqrt(g_p), N'_w the same
 * with phi(p).
 * HKS_t(w) = sum_i exp(-t lambda_i) phi_i(w)^2 follows.
 *
 * Nothing of size n x eigen_count is ever held. Every vertex is extended
 * when asked for, by blocks of nearby vertices that share their candidate
 * samples: the kernel weights of a block form a small dense matrix, and
 * one single-precision matrix product with the samples' eigenvectors gives
 * all N'_w (and s'_w, s_w) at once. Single precision costs about 1e-6
 * relative on values whose method error is 1e-3 and above, and makes
 * faster what is the largest part of HKS-simp on large meshes
 * (docs/benchmarks.md). The
 * one-vertex path (phks__extend_hks_at, for feature vectors) is double.
 */
#include "spectrum/simp.h"
#include "core/simd.h"

#include <stdatomic.h>

/* Vertices of a block extended by one matrix product. */
#define CHUNK 256
/* The product's columns (eigenvectors, then s'_w and s_w) are padded to a
 * multiple of this. */
#define LANES 16
/* Blocks are grid cells of about CHUNK vertices, and at most this
 * fraction of the cut-off radius across: the samples within reach of a
 * block's box are all in its product, so the smaller the cell the fewer
 * wasted (about 1.4x those within reach of each vertex at a third of the
 * radius, 1.15x at a tenth). */
#define CELL_FRACTION 0.34
/* The denominators are kept above this fraction of s'_w. With the literal
 * operator they approach 0 where the kernel density is low (half its
 * interior value at a mesh boundary, less at sharp tips) for eigenvalues
 * near density / 4 pi h^2; with the random walk, for eigenvalues near
 * 1 / h. There the formula amplifies sampling errors without bound.
 * A higher floor flattens the HKS at tips, a lower one lets the extension
 * make spikes of its own; 0.1 was best on meshes with sharp tips and
 * with boundaries (docs/benchmarks.md). */
#define DEN_FLOOR 0.1
/* Vertices per batch of blocks between progress reports: small enough
 * that reports come often and a cancellation is noticed promptly, large
 * enough that they cost nothing (docs/benchmarks.md). The split never
 * changes the numbers: each block is computed on its own. */
#define BATCH_VERTICES 8192
#define EIGEN_BLOCK 64

void phks__extension_free(struct phks__extension *ext)
{
    if (!ext)
        return;
    phks__free(ext->vertex);
    phks__free(ext->area);
    phks__free(ext->root_gain);
    phks__free(ext->mass);
    phks__free(ext->sample_xyz);
    phks__free(ext->vertex_xyz);
    phks__free(ext->rows);
    phks__grid_release(&ext->grid);
    phks__free(ext);
}

phks_status phks__extension_create(phks_spectrum *spec,
                                   const phks__unit_mesh *um,
                                   phks__samples *samples, double *mass)
{
    const phks_mesh *mesh = um->mesh;
    const double scale = um->scale;
    struct phks__extension *ext = phks__calloc(1, sizeof *ext);
    if (!ext) {
        phks__free(mass);
        return phks__fail_oom("extension");
    }
    size_t m = samples->count, n = mesh->vertex_count, k = spec->count;
    ext->m = m;
    ext->vertex = samples->vertex;
    ext->area = samples->area;
    ext->root_gain = samples->gain;
    ext->mass = mass;
    samples->vertex = NULL;
    samples->area = NULL;
    samples->gain = NULL;
    ext->h = spec->options.tau;
    ext->radius = spec->options.cutoff * sqrt(4 * ext->h);
    ext->random_walk = spec->options.operator_kind == PHKS_OPERATOR_RANDOM_WALK;
    ext->sample_xyz = phks__malloc_array(m, 3 * sizeof *ext->sample_xyz);
    ext->vertex_xyz = phks__malloc_array(n, 3 * sizeof *ext->vertex_xyz);
    ext->rows = phks__malloc_array(m, k * sizeof *ext->rows);
    phks_status st = PHKS_OK;
    if (!ext->sample_xyz || !ext->vertex_xyz || !ext->rows)
        st = phks__fail_oom("extension");
    if (st == PHKS_OK) {
        for (size_t i = 0; i < 3 * n; i++)
            ext->vertex_xyz[i] = mesh->xyz[i] * scale;
        for (size_t s = 0; s < m; s++)
            memcpy(ext->sample_xyz + 3 * s,
                   ext->vertex_xyz + 3 * (size_t)ext->vertex[s],
                   3 * sizeof(double));
        for (size_t s = 0; s < m; s++)
            for (size_t i = 0; i < k; i++)
                ext->rows[s * k + i] = spec->vectors[i * m + s];
        st = phks__grid_build(ext->sample_xyz, m, 1, ext->radius, &ext->grid);
        for (size_t s = 0; s < m; s++) {
            ext->total_area += ext->area[s];
            ext->root_gain[s] = sqrt(ext->root_gain[s]);
        }
    }
    if (st != PHKS_OK) {
        phks__extension_free(ext);
        return st;
    }
    spec->ext = ext;
    return PHKS_OK;
}

/* The decay exp(-t lambda_i) and the term of lambda_i in the denominator:
 * 4 pi h^2 lambda_i (literal: subtracted from s_w) or h lambda_i (random
 * walk: s_w times one minus it). */
static void eigen_terms(const phks_spectrum *spec, double t, size_t i,
                        double *decay, double *mu)
{
    const struct phks__extension *ext = spec->ext;
    *decay = exp(-t * spec->values[i]);
    *mu = ext->random_walk ? ext->h * spec->values[i]
                           : 4 * PHKS__PI * ext->h * ext->h * spec->values[i];
}

/* The denominator from s_w, s'_w and the eigenvalue term mu. */
static double denominator(bool random_walk, double s, double sg, double mu)
{
    double den = sg - mu * (random_walk ? s * s : s) / sg;
    return den > DEN_FLOOR * sg ? den : DEN_FLOOR * sg;
}

double phks__extend_hks_at(const phks_spectrum *spec, double t, size_t v)
{
    const struct phks__extension *ext = spec->ext;
    const phks__grid *g = &ext->grid;
    const double *p = ext->vertex_xyz + 3 * v;
    const double r2 = ext->radius * ext->radius, inv4h = 1 / (4 * ext->h);
    size_t c[3], range[9][2], k = spec->count;
    phks__grid_cell(g, p, c);
    size_t runs = phks__grid_neighbourhood(g, c, range);
    double sum = 0;
    /* Eigenpairs in blocks, so that no allocation is needed: the kernel
     * weights are recomputed for each block. */
    for (size_t i0 = 0; i0 < k; i0 += EIGEN_BLOCK) {
        size_t nb = k - i0 < EIGEN_BLOCK ? k - i0 : EIGEN_BLOCK;
        double acc[EIGEN_BLOCK] = {0}, s = 0, sg = 0;
        for (size_t run = 0; run < runs; run++)
            for (size_t q = range[run][0]; q < range[run][1]; q++) {
                uint32_t smp = g->points[q];
                const double *r = ext->sample_xyz + 3 * (size_t)smp;
                double dx = r[0] - p[0], dy = r[1] - p[1], dz = r[2] - p[2];
                double d2 = dx * dx + dy * dy + dz * dz;
                if (d2 >= r2)
                    continue;
                double w = ext->area[smp] * phks__exp_neg(d2 * inv4h);
                double wg = w * ext->root_gain[smp];
                const double *row = ext->rows + (size_t)smp * k + i0;
                s += w;
                sg += wg;
                for (size_t j = 0; j < nb; j++)
                    acc[j] += wg * row[j];
            }
        if (!(sg > 0))
            return 0;
        for (size_t j = 0; j < nb; j++) {
            double decay, mu;
            eigen_terms(spec, t, i0 + j, &decay, &mu);
            double phi = acc[j] / denominator(ext->random_walk, s, sg, mu);
            sum += decay * phi * phi;
        }
    }
    return sum;
}

/* ---------------------------------------------------------------------
 * Every vertex
 * --------------------------------------------------------------------- */

typedef struct {
    const phks_spectrum *spec;
    const phks__grid *cells;  /* over the mesh's vertices */
    const size_t *work;      /* non-empty cells */
    const float *rows;       /* m x stride, single precision: sqrt(g_p)
                                phi_i(p), then sqrt(g_p) and 1 (and zeros
                                to the stride), so that the product gives
                                N'_w, s'_w and s_w */
    size_t stride;
    const double *decay, *mu;
    double *out;
    atomic_int failed;
} bulk_ctx;

/* Per-worker buffers, grown as needed. */
typedef struct {
    size_t room;          /* candidates they hold                          */
    uint32_t *cand;       /* candidate samples of the current cell         */
    double *cx, *cy, *cz, *ca; /* their positions and areas                */
    double *e, *d2;       /* room: kernel values and squared distances     */
    float *f;             /* room x stride: their rows                     */
    float *w;             /* CHUNK x room: kernel weights                  */
    float *g;             /* CHUNK x stride: the product                   */
    double *term;         /* k                                             */
} scratch;

static void scratch_free(scratch *sc)
{
    phks__free(sc->cand);
    phks__free(sc->cx);
    phks__free(sc->cy);
    phks__free(sc->cz);
    phks__free(sc->ca);
    phks__free(sc->e);
    phks__free(sc->d2);
    phks__free(sc->f);
    phks__free(sc->w);
    phks__free(sc->g);
    phks__free(sc->term);
}

static bool grow(scratch *sc, size_t need, size_t k, size_t stride)
{
    if (need <= sc->room)
        return true;
    size_t room = need + need / 2 + 64;
    scratch fresh = {0};
    fresh.room = room;
    fresh.cand = phks__malloc_array(room, sizeof *fresh.cand);
    fresh.cx = phks__malloc_array(room, sizeof *fresh.cx);
    fresh.cy = phks__malloc_array(room, sizeof *fresh.cy);
    fresh.cz = phks__malloc_array(room, sizeof *fresh.cz);
    fresh.ca = phks__malloc_array(room, sizeof *fresh.ca);
    fresh.e = phks__malloc_array(room, sizeof *fresh.e);
    fresh.d2 = phks__malloc_array(room, sizeof *fresh.d2);
    fresh.f = phks__malloc_array(room, stride * sizeof *fresh.f);
    fresh.w = phks__malloc_array(room, CHUNK * sizeof *fresh.w);
    fresh.g = sc->g ? sc->g : phks__malloc_array(CHUNK, stride * sizeof *fresh.g);
    fresh.term = sc->term ? sc->term : phks__malloc_array(k, sizeof *fresh.term);
    sc->g = NULL;
    sc->term = NULL;
    scratch_free(sc);
    *sc = fresh;
    if (!fresh.cand || !fresh.cx || !fresh.cy || !fresh.cz || !fresh.ca ||
        !fresh.e || !fresh.d2 || !fresh.f || !fresh.w || !fresh.g ||
        !fresh.term) {
        sc->room = 0;
        return false;
    }
    return true;
}

/* The samples within the cut-off of the box [lo, hi]: their count, and
 * their indices in cand when they fit in room. */
static size_t candidates_of_box(const struct phks__extension *ext,
                                const double lo[3], const double hi[3],
                                uint32_t *cand, size_t room)
{
    const phks__grid *g = &ext->grid;
    double r = ext->radius, r2 = r * r;
    size_t a[3], b[3], count = 0;
    double elo[3], ehi[3];
    for (int d = 0; d < 3; d++) {
        elo[d] = lo[d] - r;
        ehi[d] = hi[d] + r;
    }
    phks__grid_cell(g, elo, a);
    phks__grid_cell(g, ehi, b);
    for (size_t z = a[2]; z <= b[2]; z++)
        for (size_t y = a[1]; y <= b[1]; y++)
            for (size_t x = a[0]; x <= b[0]; x++) {
                size_t cell = phks__grid_cell_index(g, x, y, z);
                for (size_t q = g->cell_start[cell]; q < g->cell_start[cell + 1]; q++) {
                    uint32_t smp = g->points[q];
                    const double *p = ext->sample_xyz + 3 * (size_t)smp;
                    double d2 = 0;
                    for (int d = 0; d < 3; d++) {
                        double e = p[d] < lo[d] ? lo[d] - p[d]
                                   : p[d] > hi[d] ? p[d] - hi[d] : 0;
                        d2 += e * e;
                    }
                    if (d2 >= r2)
                        continue;
                    if (count < room)
                        cand[count] = smp;
                    count++;
                }
            }
    return count;
}

/* Kernel weights A_p W(w, p) of one vertex against the nc candidates,
 * into w (single precision for the product). */
static void weights(const scratch *sc, size_t nc, const double *p, double r2,
                    double inv4h, float *w)
{
    phks__kernel_row(sc->cx, sc->cy, sc->cz, nc, p, r2, inv4h, sc->e, sc->d2);
    for (size_t j = 0; j < nc; j++)
        w[j] = (float)(sc->ca[j] * sc->e[j]);
}

/* HKS from the product row g (N'_w for k eigenvectors, s'_w, s_w). */
static double hks_of_row(const bulk_ctx *b, const float *g, size_t k,
                         double *term)
{
    double sg = g[k], s = g[k + 1];
    if (!(sg > 0))
        return 0;
    double floor = DEN_FLOOR * sg;
    double ratio = (b->spec->ext->random_walk ? s * s : s) / sg;
    for (size_t i = 0; i < k; i++) {
        double den = sg - b->mu[i] * ratio;
        den = den > floor ? den : floor;
        double phi = g[i] / den;
        term[i] = b->decay[i] * phi * phi;
    }
    double sum = 0;
    for (size_t i = 0; i < k; i++)
        sum += term[i];
    return sum;
}

/* g (nv x stride) = w (nv x nc) f (nc x stride), single precision, row
 * major, stride a multiple of LANES. A product this small (a few hundred
 * each way) gains little from BLAS, whose own threads would compete with
 * the workers here; this one sums every entry in the same order on any
 * thread count. */
static void product_base(const float *w, const float *f, float *g, size_t nv,
                         size_t nc, size_t stride)
{
    for (size_t a = 0; a < nv; a++) {
        float *out = g + a * stride;
        for (size_t c = 0; c < stride; c++)
            out[c] = 0;
        for (size_t j = 0; j < nc; j++) {
            float x = w[a * nc + j];
            const float *row = f + j * stride;
            for (size_t c = 0; c < stride; c++)
                out[c] += x * row[c];
        }
    }
}

#if PHKS__HAVE_AVX2
/* Six rows by sixteen columns at a time: twelve accumulators, two loads
 * of f and six broadcasts of w per step. */
__attribute__((target("avx2,fma"))) static void
product_avx2(const float *w, const float *f, float *g, size_t nv, size_t nc,
             size_t stride)
{
    for (size_t c = 0; c < stride; c += LANES) {
        size_t a = 0;
        for (; a + 6 <= nv; a += 6) {
            __m256 acc[6][2];
            for (int i = 0; i < 6; i++)
                acc[i][0] = acc[i][1] = _mm256_setzero_ps();
            const float *wr = w + a * nc;
            for (size_t j = 0; j < nc; j++) {
                const float *row = f + j * stride + c;
                __m256 f0 = _mm256_loadu_ps(row), f1 = _mm256_loadu_ps(row + 8);
                for (int i = 0; i < 6; i++) {
                    __m256 x = _mm256_broadcast_ss(wr + (size_t)i * nc + j);
                    acc[i][0] = _mm256_fmadd_ps(x, f0, acc[i][0]);
                    acc[i][1] = _mm256_fmadd_ps(x, f1, acc[i][1]);
                }
            }
            for (int i = 0; i < 6; i++) {
                _mm256_storeu_ps(g + (a + i) * stride + c, acc[i][0]);
                _mm256_storeu_ps(g + (a + i) * stride + c + 8, acc[i][1]);
            }
        }
        for (; a < nv; a++) {
            __m256 acc0 = _mm256_setzero_ps(), acc1 = _mm256_setzero_ps();
            for (size_t j = 0; j < nc; j++) {
                const float *row = f + j * stride + c;
                __m256 x = _mm256_broadcast_ss(w + a * nc + j);
                acc0 = _mm256_fmadd_ps(x, _mm256_loadu_ps(row), acc0);
                acc1 = _mm256_fmadd_ps(x, _mm256_loadu_ps(row + 8), acc1);
            }
            _mm256_storeu_ps(g + a * stride + c, acc0);
            _mm256_storeu_ps(g + a * stride + c + 8, acc1);
        }
    }
}
#endif

static void product(const float *w, const float *f, float *g, size_t nv,
                    size_t nc, size_t stride)
{
#if PHKS__HAVE_AVX2
    if (phks__cpu_avx2()) {
        product_avx2(w, f, g, nv, nc, stride);
        return;
    }
#endif
    product_base(w, f, g, nv, nc, stride);
}

static void extend_cells(void *ctx, size_t begin, size_t end)
{
    bulk_ctx *b = ctx;
    const phks_spectrum *spec = b->spec;
    const struct phks__extension *ext = spec->ext;
    const phks__grid *cells = b->cells;
    const size_t k = spec->count, k1 = b->stride;
    const double r2 = ext->radius * ext->radius, inv4h = 1 / (4 * ext->h);
    scratch sc = {0};
    bool ok = grow(&sc, 512, k, k1);
    for (size_t wi = begin; ok && wi < end; wi++) {
        size_t cell = b->work[wi];
        size_t first = cells->cell_start[cell], last = cells->cell_start[cell + 1];
        double lo[3] = {INFINITY, INFINITY, INFINITY};
        double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t q = first; q < last; q++) {
            const double *p = ext->vertex_xyz + 3 * (size_t)cells->points[q];
            for (int d = 0; d < 3; d++) {
                lo[d] = fmin(lo[d], p[d]);
                hi[d] = fmax(hi[d], p[d]);
            }
        }
        size_t nc = candidates_of_box(ext, lo, hi, sc.cand, sc.room);
        if (nc > sc.room) {
            if (!(ok = grow(&sc, nc, k, k1)))
                break;
            candidates_of_box(ext, lo, hi, sc.cand, sc.room);
        }
        for (size_t j = 0; j < nc; j++) {
            const double *p = ext->sample_xyz + 3 * (size_t)sc.cand[j];
            sc.cx[j] = p[0];
            sc.cy[j] = p[1];
            sc.cz[j] = p[2];
            sc.ca[j] = ext->area[sc.cand[j]];
            memcpy(sc.f + j * k1, b->rows + (size_t)sc.cand[j] * k1,
                   k1 * sizeof(float));
        }
        for (size_t c0 = first; c0 < last; c0 += CHUNK) {
            size_t nv = last - c0 < CHUNK ? last - c0 : CHUNK;
            if (nc == 0) {
                for (size_t a = 0; a < nv; a++)
                    b->out[cells->points[c0 + a]] = 0;
                continue;
            }
            for (size_t a = 0; a < nv; a++)
                weights(&sc, nc, ext->vertex_xyz + 3 * (size_t)cells->points[c0 + a],
                        r2, inv4h, sc.w + a * nc);
            product(sc.w, sc.f, sc.g, nv, nc, k1);
            for (size_t a = 0; a < nv; a++)
                b->out[cells->points[c0 + a]] = hks_of_row(b, sc.g + a * k1, k, sc.term);
        }
    }
    if (!ok)
        atomic_store(&b->failed, 1);
    scratch_free(&sc);
}

phks_status phks__extend_hks(const phks_spectrum *spec, double t,
                            const phks_options *opt, unsigned threads,
                            double *out)
{
    const struct phks__extension *ext = spec->ext;
    size_t n = spec->n, m = ext->m, k = spec->count;
    phks__grid cells = {0};
    size_t *work = NULL;
    double *decay = phks__malloc_array(k, sizeof *decay);
    double *mu = phks__malloc_array(k, sizeof *mu);
    size_t stride = (k + 2 + LANES - 1) / LANES * LANES;
    float *rows = phks__calloc(m, stride * sizeof *rows);
    phks_status st = PHKS_OK;
    if (!decay || !mu || !rows)
        st = phks__fail_oom("HKS extension");
    /* Blocks: cells holding about CHUNK vertices (a surface of area S
     * occupies about 1.5 S / b^2 cells of edge b), at most CELL_FRACTION
     * of the cut-off across. The smaller the cell, the fewer samples out
     * of reach of its vertices enter the product. */
    double cell = CELL_FRACTION * ext->radius;
    if (st == PHKS_OK) {
        double per = sqrt(CHUNK * ext->total_area / (1.5 * (double)n));
        if (per < cell)
            cell = per;
        st = phks__grid_build(ext->vertex_xyz, n, 1, cell, &cells);
    }
    size_t total = 0;
    if (st == PHKS_OK) {
        size_t all = cells.dims[0] * cells.dims[1] * cells.dims[2];
        for (size_t c = 0; c < all; c++)
            total += cells.cell_start[c + 1] > cells.cell_start[c];
        work = phks__malloc_array(total ? total : 1, sizeof *work);
        if (!work)
            st = phks__fail_oom("HKS extension");
        total = 0;
        for (size_t c = 0; work && c < all; c++)
            if (cells.cell_start[c + 1] > cells.cell_start[c])
                work[total++] = c;
    }
    if (st == PHKS_OK) {
        for (size_t i = 0; i < k; i++)
            eigen_terms(spec, t, i, decay + i, mu + i);
        for (size_t s = 0; s < m; s++) {
            double root = ext->root_gain[s];
            for (size_t i = 0; i < k; i++)
                rows[s * stride + i] = (float)(root * ext->rows[s * k + i]);
            rows[s * stride + k] = (float)root;
            rows[s * stride + k + 1] = 1;
        }
        bulk_ctx b = {spec, &cells, work, rows, stride, decay, mu, out, 0};
        size_t batches = 1 + n / BATCH_VERTICES;
        phks__span at = {opt, PHKS_STAGE_HKS, 0, 1};
        st = phks__run_batched(total, threads, extend_cells, &b, at,
                               batches < total ? batches : total);
        if (st == PHKS_OK && atomic_load(&b.failed))
            st = phks__fail_oom("HKS extension");
    }
    if (st == PHKS_OK && opt)
        st = phks__progress(opt, PHKS_STAGE_HKS, 1);
    phks__grid_release(&cells);
    phks__free(work);
    phks__free(decay);
    phks__free(mu);
    phks__free(rows);
    return st;
}
