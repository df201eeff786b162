/*
 * phks.h - libphks, persistent heat signatures for pose-oblivious matching
 * of complete, partial and incomplete triangle meshes.
 *
 * This header is the manual. Every function states what it does, the units
 * of its numbers, who owns what, the statuses it returns and whether it may
 * be called from several threads at once.
 *
 * The method is Dey, Li, Luo, Ranjan, Safa, Wang: "Persistent Heat Signature
 * for Pose-oblivious Matching of Incomplete Models" (SGP 2010):
 *
 *   mesh --(normalise to a unit box)--> Belkin-Sun-Wang mesh-Laplacian
 *        --(smallest eigenpairs)------> heat kernel signature HKS_t
 *        --(persistence region merging of HKS at t = 5 tau)--> feature points
 *        --(HKS at 15 time scales per feature point)--> signature
 *   two signatures --(symmetric sum of nearest L1 distances)--> score
 *
 * Conventions that hold everywhere:
 * - Every function that can fail returns a phks_status. On failure, output
 *   handles are set to NULL, nothing is leaked, and
 *   phks_last_error_message() tells what went wrong and where.
 * - The library never prints, never aborts and never exits.
 * - Handles are opaque. A handle is created by exactly one *_create, *_load,
 *   *_compute or *_decode function and released by its *_free function;
 *   *_free(NULL) does nothing.
 * - Thread-safety: functions that take only const handles may be called
 *   from any number of threads at once on the same handles. A handle must
 *   not be freed while another thread uses it. phks_set_allocator() is the
 *   one function that must be called before any other thread uses the
 *   library.
 * - Determinism: on one machine and one build of the library and of the
 *   BLAS, results (a signature's blob, every score) are the same bits on
 *   every run, whatever the threads option and the BLAS's own thread count
 *   (OPENBLAS_NUM_THREADS). Not across BLAS builds, nor across processors
 *   where the library's run-time kernel choice (AVX2 and FMA) or the
 *   BLAS's (OpenBLAS picks its kernels by processor) differs; and
 *   with PHKS_SOLVER_ARPACK, ARPACK's own BLAS calls may round differently
 *   with the BLAS's thread count (docs/guide.md, "Threads").
 * - Pointers returned by accessors stay valid until the handle is freed.
 * - Index types: vertex and triangle indices are uint32_t; counts are size_t.
 */
#ifndef PHKS_H
#define PHKS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(PHKS_BUILDING_DLL)
#define PHKS_API __declspec(dllexport)
#elif defined(__GNUC__) || defined(__clang__)
#define PHKS_API __attribute__((visibility("default")))
#else
#define PHKS_API
#endif

/* =====================================================================
 * Versions
 * =====================================================================
 * The package version below is the single source of truth: the build reads
 * it from here. PHKS_ABI_VERSION is the SONAME major (libphks.so.N); it
 * changes only when a published function or struct layout changes
 * incompatibly. Versions with the same ABI version are binary compatible:
 * a program built against an older header runs with a newer library.
 */
#define PHKS_VERSION_MAJOR 0
#define PHKS_VERSION_MINOR 2
#define PHKS_VERSION_PATCH 0
#define PHKS_VERSION_NUMBER \
    (PHKS_VERSION_MAJOR * 10000 + PHKS_VERSION_MINOR * 100 + PHKS_VERSION_PATCH)
#define PHKS_ABI_VERSION 1

/* The library's own PHKS_VERSION_NUMBER, which may differ from the header's
 * when a program runs against a newer shared library. Thread-safe. */
PHKS_API unsigned phks_version_number(void);
/* "MAJOR.MINOR.PATCH" of the library, a static string. Thread-safe. */
PHKS_API const char *phks_version_string(void);

/* =====================================================================
 * Status codes
 * =====================================================================
 * Values are frozen: new codes are only ever appended.
 */
typedef enum phks_status {
    PHKS_OK = 0,
    PHKS_ERROR_INVALID_ARGUMENT = 1,  /* NULL where not allowed, bad option  */
    PHKS_ERROR_OUT_OF_MEMORY = 2,     /* an allocation failed                */
    PHKS_ERROR_IO = 3,                /* a file could not be opened or read  */
    PHKS_ERROR_UNKNOWN_FORMAT = 4,    /* not OFF, OBJ, PLY or STL            */
    PHKS_ERROR_PARSE = 5,             /* malformed content (syntax, types)   */
    PHKS_ERROR_TRUNCATED = 6,         /* data ends before the header says    */
    PHKS_ERROR_NON_FINITE = 7,        /* a NaN or infinite number            */
    PHKS_ERROR_INDEX_OUT_OF_RANGE = 8,/* a face names a missing vertex       */
    PHKS_ERROR_NO_TRIANGLES = 9,      /* nothing to triangulate              */
    PHKS_ERROR_ZERO_AREA = 10,        /* all triangles degenerate, or a mesh
                                         with no extent (a point, a line)    */
    PHKS_ERROR_TOO_LARGE = 11,        /* counts, extent or area beyond limits,
                                         or counts the data could not hold   */
    PHKS_ERROR_CANCELLED = 12,        /* the progress callback asked to stop */
    PHKS_ERROR_NO_CONVERGENCE = 13,   /* the eigen-solver did not converge   */
    PHKS_ERROR_INCOMPATIBLE = 14,     /* signatures made with other options  */
    PHKS_ERROR_CORRUPT = 15,          /* a blob failed its checksum or shape */
    PHKS_ERROR_UNSUPPORTED_VERSION = 16, /* a blob from a newer format       */
    PHKS_ERROR_BUFFER_TOO_SMALL = 17, /* the caller's buffer is too small    */
    PHKS_ERROR_SOLVER = 18            /* LAPACK or ARPACK reported a failure */
} phks_status;

/* A short static English description of a status ("out of memory").
 * Unknown values give "unknown status". Thread-safe. */
PHKS_API const char *phks_status_string(phks_status status);

/* The detail of the last failure in the calling thread, for example
 * "bunny.ply: line 14: vertex 3: coordinate is not finite". Each thread has
 * its own message, so threads never see each other's errors. The string is
 * owned by the library and valid until the next failing call in the same
 * thread. Successful calls leave it unchanged. "" if nothing failed yet. */
PHKS_API const char *phks_last_error_message(void);

/* =====================================================================
 * Memory
 * =====================================================================
 * All memory the library itself allocates goes through these functions.
 * (OpenBLAS, LAPACK and ARPACK allocate their own small internal buffers
 * through the C library; those are outside this hook.)
 */
typedef struct phks_allocator {
    void *(*malloc_fn)(void *user, size_t size);
    void *(*realloc_fn)(void *user, void *ptr, size_t size);
    void (*free_fn)(void *user, void *ptr);
    void *user;
} phks_allocator;

/* Replaces the allocator; NULL restores malloc/realloc/free. The three
 * functions must be thread-safe and must all be set. Call it before any
 * other phks_* call and before any handle exists: memory is released with
 * the allocator in force when it is freed. Returns PHKS_OK, or
 * PHKS_ERROR_INVALID_ARGUMENT when a function pointer is NULL. */
PHKS_API phks_status phks_set_allocator(const phks_allocator *allocator);

/* =====================================================================
 * Options
 * =====================================================================
 * The parameters of the method. Always start from phks_options_init(), then
 * change fields. The struct has a fixed size for the whole ABI version: new
 * fields are carved out of `reserved`, where zero means the paper's
 * behaviour. phks_options_init() gives the library's recommended values,
 * which may depart from the paper where measurements say so (the CHANGELOG
 * records every change of default); signatures record every field that
 * shapes their numbers, so a changed default never mixes incomparable
 * signatures.
 */
#define PHKS_OPTIONS_VERSION 1
#define PHKS_MAX_SCALES 32

/* How the heat operator is normalised. */
typedef enum phks_operator {
    /* The paper's operator: S phi = lambda M phi, M = diag(vertex areas). */
    PHKS_OPERATOR_LITERAL = 0,
    /* Random-walk normalisation D^-1 L (the paper's appendix B D):
     * S phi = lambda M D phi. D is the kernel density at each vertex; it
     * evens out HKS at boundaries and at sparsely sampled spots. */
    PHKS_OPERATOR_RANDOM_WALK = 1
} phks_operator;

/* How the mesh is scaled to a unit box before anything else. */
typedef enum phks_box {
    /* Longest side of the box aligned with the principal axes of the
     * surface is 1. Invariant to rotations of the input. */
    PHKS_BOX_PRINCIPAL = 0,
    /* Longest side of the axis-aligned bounding box is 1 (the paper's
     * choice; changes when the input is rotated). */
    PHKS_BOX_AXIS_ALIGNED = 1
} phks_box;

/* How HKS values are scaled before they are compared. */
typedef enum phks_hks_scaling {
    /* The paper's HKS_t(x) = sum_i exp(-t lambda_i) phi_i(x)^2. */
    PHKS_HKS_SCALING_NONE = 0,
    /* HKS_t(x) divided by its mass-weighted mean over the mesh, which is
     * the heat trace sum_i exp(-t lambda_i) over the total mass. Removes
     * the 1/area level that large t approaches, which a partial scan or a
     * cut model shares with nothing: only the shape of the heat remains.
     * Measured worse than NONE on every kind of query (docs/retrieval.md). */
    PHKS_HKS_SCALING_MEAN = 1,
    /* log(HKS_t(x) A_t(x) / (4 pi t)), A_t(x) the area of the mesh within
     * straight-line distance sqrt(4 t) of x (the heat kernel's width), all
     * in the unit box; -log(4 pi t) on a plane (where HKS_t A_t is 1), a
     * constant per scale that drops out of every L1 distance between
     * signatures (docs/method.md section 9). A partial scan keeps one side
     * of a thin part, where the heat that spread over both sides now stays
     * on one: HKS_t doubles and A_t halves, so the product is what the scan
     * shares with its whole. The logarithm makes the L1 distance weigh
     * every time scale alike. Feature vectors only: feature points are
     * chosen as with NONE. The default since 0.2.0 (docs/retrieval.md). */
    PHKS_HKS_SCALING_LOCAL_AREA = 2
} phks_hks_scaling;

/* Where the operator takes its quadrature (its sum over the surface). */
typedef enum phks_quadrature {
    /* At the vertices, each weighted by a third of the area of its
     * triangles (the paper). Where vertices lie farther apart than the
     * kernel's width sqrt(4 tau) (a CAD part's flat face as two long
     * triangles) the kernel does not reach across and heat does not
     * cross the face: the signature describes the tessellation. The
     * default of 0.2.0. */
    PHKS_QUADRATURE_VERTICES = 0,
    /* Also inside every triangle whose longest edge exceeds sqrt(4 tau)
     * (unit box): it is covered by a triangular lattice of side at most
     * sqrt(4 tau), as many points as its area needs whatever its shape,
     * each carrying a third of the area of the lattice's triangles at it.
     * The operator is built on these points and its eigenvectors are read
     * at the vertices (which are among them): vertex ids stay the input's
     * and no point is visible outside the library. The local areas of
     * PHKS_HKS_SCALING_LOCAL_AREA and the principal box integrate over the
     * triangles too. A mesh without such a triangle gets the same
     * numbers as with VERTICES (docs/method.md section 13), though its
     * options, which record TRIANGLES, keep the two from being compared.
     * The points can be a few times the vertices (3.2 x on PSB's coarsest
     * Bearing models, 1.04 x over all of PSB) and the solve is exact on
     * all of them: time and memory grow with them (docs/benchmarks.md).
     * Meshes on the HKS-simp path keep the vertices' operator. The
     * default since 0.3.0. */
    PHKS_QUADRATURE_TRIANGLES = 1
} phks_quadrature;

/* How phks_score compares two signatures (see "Scoring and
 * correspondences"). */
typedef enum phks_matching {
    /* The paper's: each feature's nearest feature vector in the other
     * signature, by L1 distance, summed both ways. Symmetric. Every point
     * is judged alone, so a partial scan whose points resemble some of
     * another class's is taken for it. */
    PHKS_MATCHING_NEAREST = 0,
    /* Correspondences verified by intrinsic geometry: the signature also
     * keeps samples spread over the surface and the distances along it
     * between all its points, and the paper's score is discounted by
     * the share of the query's features that a set of correspondences
     * explains whose vectors are close and whose distances agree (up to
     * a scale, since the unit box enlarges a cut shape, and allowing a
     * cut shape's distances to be longer, since a cut can only lengthen
     * a path). Asymmetric: query first, entry second (docs/method.md
     * section 14; measured in docs/retrieval.md). The default since
     * 0.2.0. */
    PHKS_MATCHING_VERIFIED = 1
} phks_matching;

/* What proposes the correspondences that PHKS_MATCHING_VERIFIED checks:
 * the description of the surface around each of a signature's points
 * (features and samples). Since 0.3.0. */
typedef enum phks_local_descriptor {
    /* The feature vectors themselves (HKS at the 15 time scales), as
     * 0.2.0 did. Heat at the larger scales sums over the whole shape, so
     * a cut changes every vector. The value a zeroed field holds. */
    PHKS_LOCAL_DESCRIPTOR_HEAT = 0,
    /* Spin images (Johnson and Hebert 1999) of the surface within
     * straight-line balls of five radii around each point, on a ladder of
     * steps of sqrt(2) (so a change of scale is a shift along it): how
     * the area of the surface, integrated over its triangles, lies by
     * distance from the point's normal line and height along it. Local
     * and extrinsic: a cut or a pose change away from the ball leaves it
     * alone. Orientation-free (the normal's sign is taken from the
     * surface itself), so triangle soups with inconsistent winding get
     * the same images. 100 more bytes per point in a blob
     * (docs/method.md section 15), and a verified query takes about 1.3
     * times as long (docs/benchmarks.md). The default since 0.3.0. Spin
     * images do not tell a point from its mirror image, so on a
     * symmetric shape the verified partner may be a feature's mirror
     * twin. */
    PHKS_LOCAL_DESCRIPTOR_SPIN = 1
} phks_local_descriptor;

/* A description of the whole shape beside the feature points, which
 * PHKS_MATCHING_VERIFIED multiplies into its score. Since 0.3.0. */
typedef enum phks_global_descriptor {
    /* None: the score is the feature points' alone, as 0.2.0's. */
    PHKS_GLOBAL_DESCRIPTOR_NONE = 0,
    /* The shape distribution D2 (Osada, Funkhouser, Chazelle and Dobkin
     * 2002): the histogram of straight-line distances between points
     * spread over the surface by area, in units of their mean, so that
     * neither scale, pose in space nor triangulation changes it. Rigid
     * and global: it tells rigid parts apart by their overall proportions
     * (a catalogue of CAD parts), and changes with an articulated shape's
     * pose and with a cut. The verified score is multiplied by the
     * distributions' Hellinger distance plus the distance two samplings
     * of one surface keep (docs/method.md section 16). 32 more bytes in a
     * blob. */
    PHKS_GLOBAL_DESCRIPTOR_D2 = 1
} phks_global_descriptor;

typedef enum phks_solver {
    /* Dense LAPACK for small meshes, block Lanczos above. */
    PHKS_SOLVER_AUTO = 0,
    /* Block Lanczos with full re-orthogonalisation (BLAS3). Thread-safe. */
    PHKS_SOLVER_LANCZOS = 1,
    /* ARPACK-NG (implicitly restarted Lanczos). The reference; slower.
     * ARPACK keeps global state, so the library serialises these calls. */
    PHKS_SOLVER_ARPACK = 2,
    /* Dense on the full matrix: the library's own tridiagonal reduction,
     * LAPACK's bisection and inverse iteration (dstebz, dstein). O(n^2)
     * memory, O(n^3) time: meant for meshes of a few thousand vertices. */
    PHKS_SOLVER_DENSE = 3
} phks_solver;

/* Stages reported to the progress callback, in order. */
typedef enum phks_stage {
    PHKS_STAGE_OPERATOR = 0,     /* building the mesh-Laplacian          */
    PHKS_STAGE_EIGEN = 1,        /* eigen-decomposition                  */
    PHKS_STAGE_HKS = 2,          /* heat kernel signature                */
    PHKS_STAGE_PERSISTENCE = 3,  /* boundary margin, region merging,
                                    feature vectors                      */
    PHKS_STAGE_COUNT = 4
} phks_stage;

/* Called from the thread that called the long-running function, with the
 * fraction of the current stage done (0..1). Return 0 to continue, non-zero
 * to cancel: the function then returns PHKS_ERROR_CANCELLED promptly, with
 * everything it made freed. Every stage reports between bounded pieces of
 * work, whatever the mesh size (the eigen-solver between operator
 * applications and between its dense steps, which cannot report from
 * inside); docs/benchmarks.md has the report intervals, the longest
 * silences and the latency of a cancellation measured on a large mesh. With
 * HKS-simp, PHKS_STAGE_OPERATOR covers choosing the samples and their
 * operator, and PHKS_STAGE_HKS the extension to every vertex.
 * PHKS_STAGE_PERSISTENCE covers the boundary margin, the region merging
 * and the feature vectors. */
typedef int (*phks_progress_fn)(void *user, phks_stage stage, double fraction);

typedef struct phks_options {
    uint32_t version;        /* PHKS_OPTIONS_VERSION; set by init        */
    uint32_t eigen_count;    /* eigenpairs computed: 300. Whole clusters
                                of equal eigenvalues only: eigenvalues
                                within 1e-6 max(|lambda|, 1 / tau) of
                                their neighbour are equal, and a cluster
                                the count would split is left out (the
                                zero eigenvalue's is kept whole, even
                                past the count); see
                                phks_spectrum_compute                    */
    double tau;              /* time unit = kernel parameter h: 0.0002,
                                for a mesh scaled to a unit box          */
    double cutoff;           /* kernel cut-off radius in units of
                                sqrt(4 tau): 3.5 (dropped weight < 5e-6)   */
    uint32_t feature_count;  /* kappa, the number of feature points: 15  */
    uint32_t scale_count;    /* number of entries used in scales: 15     */
    double scales[PHKS_MAX_SCALES]; /* HKS time scales in units of tau:
                                5 20 40 60 100 150 200 300 400 500 600 700
                                800 900 1000                              */
    double feature_scale;    /* time of the HKS whose maxima are the
                                feature points, in units of tau: 5        */
    int32_t operator_kind;   /* phks_operator: PHKS_OPERATOR_RANDOM_WALK
                                (the paper's is LITERAL; see
                                docs/retrieval.md for the measurements) */
    int32_t box;             /* phks_box: PHKS_BOX_PRINCIPAL             */
    int32_t solver;          /* phks_solver: PHKS_SOLVER_AUTO            */
    uint32_t threads;        /* worker threads for the operator and the
                                Lanczos solver's products; 0 = one per
                                CPU. Started by each computation and
                                joined before it returns. BLAS threads
                                are left to the user
                                (OPENBLAS_NUM_THREADS; on a few cores 1
                                is fastest: docs/benchmarks.md). Neither
                                count changes a bit of the results
                                (the conventions above).                 */
    double tolerance;        /* eigen-solver: residual |B x - l x| below
                                tolerance * |B|: 1e-10                   */
    phks_progress_fn progress; /* NULL: no progress reports             */
    void *progress_user;     /* passed back to progress                  */
    /* Fields below were carved out of `reserved` after 0.1.0; zero gives
     * the paper's behaviour. */
    double boundary_margin;  /* feature points are picked on HKS tapered
                                to zero at the mesh boundary: times
                                1 - exp(-(d / m)^2), d the straight-line
                                distance to the boundary in the unit box,
                                m = boundary_margin sqrt(4 feature_scale
                                tau), the width of the heat kernel the
                                points come from. Feature vectors are not
                                tapered. 2; 0 = none, as in the paper     */
    int32_t hks_scaling;     /* phks_hks_scaling: LOCAL_AREA (the paper's
                                is NONE)                                 */
    uint32_t simplify_above; /* meshes with more vertices (and more than
                                simplify_target) go through HKS-simp
                                (see Spectrum): 25000; 0 = never. Not
                                compared between signatures: a large
                                mesh stays comparable with small ones    */
    uint32_t simplify_target;/* samples HKS-simp aims for (the count
                                lands within a few percent; more is
                                closer to exact, and slower): 10000;
                                16..10^8                                 */
    int32_t quadrature;      /* phks_quadrature: TRIANGLES since 0.3.0,
                                which makes a coarsely triangulated face
                                look like a finely meshed one
                                (docs/method.md section 13; the paper's
                                and 0.2.0's is VERTICES)                 */
    int32_t matching;        /* phks_matching: VERIFIED (the paper's is
                                NEAREST). VERIFIED signatures also hold
                                the distances between their feature
                                points                                   */
    int32_t local_descriptor; /* phks_local_descriptor: what proposes the
                                correspondences VERIFIED checks: SPIN
                                since 0.3.0 (0.2.0's is HEAT; both are
                                measured in docs/retrieval.md, "Spin
                                images"). Ignored with NEAREST           */
    int32_t global_descriptor; /* phks_global_descriptor: a term of the
                                whole shape in the verified score: NONE
                                (D2 is measured in docs/retrieval.md,
                                "Shape distributions"). Ignored with
                                NEAREST                                  */
    uint32_t reserved_pad;   /* zero                                     */
    uint64_t reserved[19];   /* zero; room for fields of later versions  */
} phks_options;

/* Fills *options with the defaults above. Thread-safe. Returns
 * PHKS_ERROR_INVALID_ARGUMENT if options is NULL. */
PHKS_API phks_status phks_options_init(phks_options *options);

/* ---- Option names (since 0.2.0)
 * One table in the library names every field of phks_options that a
 * caller sets, and every value of those that are enums, in the words of
 * each kind of user, so that a binding parses and prints its users'
 * spelling and a message names what they typed. Options are numbered
 * 0, 1, ... in a fixed order that later versions only extend: the ones
 * that shape a signature's numbers first (tau, cutoff, eigen_count,
 * operator_kind, box, quadrature, feature_count, scale_count,
 * feature_scale, boundary_margin, hks_scaling, matching, scales), then
 * solver, threads, tolerance, simplify_above, simplify_target, then
 * local_descriptor and global_descriptor (since 0.3.0; they shape
 * VERIFIED signatures only).
 * Every function here is thread-safe and allocates nothing; returned
 * strings are static. */
typedef enum phks_spelling {
    /* The field's name and the enumerator's suffix in lower case:
     * "operator_kind", "random_walk". The library's own messages, the
     * Python module's keywords and PostgreSQL's phks_options use it. */
    PHKS_SPELLING_C = 0,
    /* The phks tool's: the option after "--" and its value, words joined
     * by '-': "operator", "random-walk", "hks-scaling". */
    PHKS_SPELLING_CLI = 1
} phks_spelling;

/* Name of option `index` in spelling, or NULL past the last option or for
 * a spelling this library does not know (so a loop from 0 to the first
 * NULL visits them all). */
PHKS_API const char *phks_option_name(uint32_t index, phks_spelling spelling);

/* What an option's value is: what phks_option_set reads and what a
 * binding takes from its users. */
typedef enum phks_option_type {
    PHKS_OPTION_REAL = 0,  /* a finite double (tau, boundary_margin, ...)  */
    PHKS_OPTION_COUNT = 1, /* a uint32_t (eigen_count, threads, ...)       */
    PHKS_OPTION_ENUM = 2,  /* an int32_t with named values (hks_scaling)   */
    PHKS_OPTION_REALS = 3  /* scales: 1..PHKS_MAX_SCALES doubles, and
                              scale_count with them                        */
} phks_option_type;

/* The type of option `index` into *type. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (type NULL, index past the last option). */
PHKS_API phks_status phks_option_type_of(uint32_t index,
                                         phks_option_type *type);

/* Sets *index to the option named `name` in spelling (exact match).
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, unknown spelling, no such
 * option: the message names it). */
PHKS_API phks_status phks_option_find(const char *name, phks_spelling spelling,
                                      uint32_t *index);

/* Name of `value` of option `index` in spelling when the option is an enum
 * (operator_kind, box, solver, hks_scaling, quadrature, matching,
 * local_descriptor, global_descriptor): for
 * example "local-area" for hks_scaling 2 in PHKS_SPELLING_CLI. NULL when
 * the option is not an enum, the value has no name or the spelling is
 * unknown. An enum's values are 0, 1, ... up to the first NULL. */
PHKS_API const char *phks_option_value_name(uint32_t index, int32_t value,
                                            phks_spelling spelling);

/* Sets option `index` of *options from `text` as its user typed it: an
 * enum's value by its name in spelling (or its number), a count in
 * decimal digits, a real as a finite C number, scales as numbers separated
 * by commas (which also sets scale_count). The result is validated as
 * every computation validates options; on any error *options is left as
 * it was. Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, unknown spelling or
 * index, text that is not a value of the option or out of its range: the
 * message names the option in spelling and the text). */
PHKS_API phks_status phks_option_set(phks_options *options, uint32_t index,
                                     const char *text, phks_spelling spelling);

/* Writes option `index` of *options as its user would type it in spelling
 * (an enum's name, a number in the fewest digits that read back to the
 * same double, scales separated by commas) into text, size bytes with the
 * terminating NUL. Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, unknown
 * spelling or index, an enum value with no name),
 * PHKS_ERROR_BUFFER_TOO_SMALL (text then holds as much as fits). */
PHKS_API phks_status phks_option_format(const phks_options *options,
                                        uint32_t index, phks_spelling spelling,
                                        char *text, size_t size);

/* Whether signatures made with options a and b are comparable: every option
 * that shapes a signature's numbers equal (not solver, threads, tolerance,
 * callbacks nor the HKS-simp switch, which change how the numbers are
 * computed, not what they mean; local_descriptor and global_descriptor
 * only when both match VERIFIED, since NEAREST ignores them). Returns
 * PHKS_OK when they are, and PHKS_ERROR_INCOMPATIBLE when not, with the
 * first option that differs and both values in spelling, "hks-scaling
 * local-area against none", in detail (size bytes; cut to fit; may be
 * NULL when size is 0) and in phks_last_error_message(). Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (NULL options, unknown spelling). */
PHKS_API phks_status phks_options_compare(const phks_options *a,
                                          const phks_options *b,
                                          phks_spelling spelling, char *detail,
                                          size_t size);

/* =====================================================================
 * Meshes
 * =====================================================================
 * A phks_mesh is an immutable, cleaned triangle mesh: degenerate triangles
 * (a repeated vertex, or an area below 1e-12 of the squared bounding-box
 * diagonal) and unreferenced vertices are dropped, the remaining vertices
 * renumbered in their original order. phks_mesh_vertex_origin() maps each
 * vertex back to the caller's or the file's numbering. Non-manifold edges,
 * several components and triangle soups are accepted: the operator needs
 * only positions and areas.
 */
typedef struct phks_mesh phks_mesh;

/* Creates a mesh from caller arrays, which are copied: xyz holds
 * 3 * vertex_count coordinates (x0 y0 z0 x1 ...), any unit; triangles holds
 * 3 * triangle_count vertex indices. Errors: PHKS_ERROR_INVALID_ARGUMENT
 * (NULL pointers), PHKS_ERROR_NON_FINITE, PHKS_ERROR_INDEX_OUT_OF_RANGE,
 * PHKS_ERROR_NO_TRIANGLES (triangle_count 0), PHKS_ERROR_ZERO_AREA,
 * PHKS_ERROR_TOO_LARGE (more than 2^32 - 2 vertices or 2^30 triangles),
 * PHKS_ERROR_OUT_OF_MEMORY. Thread-safe. */
PHKS_API phks_status phks_mesh_create(const double *xyz, size_t vertex_count,
                                      const uint32_t *triangles,
                                      size_t triangle_count, phks_mesh **mesh);
/* Same as phks_mesh_create with single-precision coordinates. */
PHKS_API phks_status phks_mesh_create_f(const float *xyz, size_t vertex_count,
                                        const uint32_t *triangles,
                                        size_t triangle_count, phks_mesh **mesh);

typedef enum phks_format {
    PHKS_FORMAT_AUTO = 0, /* from the content (and, for files, the name) */
    PHKS_FORMAT_OFF = 1,
    PHKS_FORMAT_OBJ = 2,
    PHKS_FORMAT_PLY = 3,  /* ascii, binary_little_endian, binary_big_endian */
    PHKS_FORMAT_STL = 4   /* ascii or binary; coincident corners welded     */
} phks_format;

/* Reads a mesh file: OFF, OBJ (polygons fan-triangulated, negative indices,
 * everything but v and f ignored), PLY (any property layout and types; a
 * face list named vertex_indices or vertex_index), STL. Each may be
 * gzip-compressed; gzip is recognised by its magic bytes, the format by the
 * name (".off", ".obj", ".ply", ".stl", each optionally followed by ".gz")
 * or else by the content. A gzip stream may inflate to at most 2 GiB.
 * Errors: PHKS_ERROR_IO, PHKS_ERROR_UNKNOWN_FORMAT, PHKS_ERROR_PARSE
 * (also damaged gzip data), PHKS_ERROR_TRUNCATED (data ends inside a
 * record, or a gzip stream is cut short), PHKS_ERROR_TOO_LARGE (declared
 * counts that the remaining bytes could not hold, or beyond 2^32 - 2), and
 * those of phks_mesh_create; the message names the file and the line
 * (text) or byte offset (binary). Faces with fewer than 3 corners are
 * refused. Thread-safe. */
PHKS_API phks_status phks_mesh_load(const char *path, phks_mesh **mesh);
/* Same as phks_mesh_load from a buffer in memory (not retained), in the
 * given format (PHKS_FORMAT_AUTO: from the content). Thread-safe. */
PHKS_API phks_status phks_mesh_load_memory(const void *data, size_t size,
                                           phks_format format,
                                           phks_mesh **mesh);
/* Same as phks_mesh_load_memory within limits, for hosts that load meshes
 * from others (a database server, a web service), so that a mesh too large
 * for the host is refused before it takes the memory and the time its
 * signature would. max_bytes bounds the data's size after gzip inflation
 * (inflation stops at the limit); max_vertices bounds the vertices the file
 * lists (STL: its distinct corners), checked once it is read and before it
 * is cleaned. 0 means no limit (gzip still stops at 2 GiB). While reading,
 * the library holds the inflated data and arrays of about three times its
 * size (the densest vertex lines), so at most about four times max_bytes;
 * a signature's memory and time then grow with the vertex count
 * (docs/benchmarks.md: about 600 MB and 30 s for 1.6 million).
 * Errors: those of phks_mesh_load_memory, and PHKS_ERROR_TOO_LARGE with a
 * message naming the limit passed. Thread-safe. */
PHKS_API phks_status phks_mesh_load_memory_limited(const void *data,
                                                   size_t size,
                                                   phks_format format,
                                                   size_t max_bytes,
                                                   size_t max_vertices,
                                                   phks_mesh **mesh);
PHKS_API void phks_mesh_free(phks_mesh *mesh);

/* Counts and arrays of the cleaned mesh. On a NULL mesh the counts are 0
 * and the arrays NULL. The arrays belong to the mesh. */
PHKS_API size_t phks_mesh_vertex_count(const phks_mesh *mesh);
PHKS_API size_t phks_mesh_triangle_count(const phks_mesh *mesh);
/* 3 * vertex_count coordinates, as given (not normalised). */
PHKS_API const double *phks_mesh_vertices(const phks_mesh *mesh);
/* 3 * triangle_count indices into phks_mesh_vertices. */
PHKS_API const uint32_t *phks_mesh_triangles(const phks_mesh *mesh);
/* For each vertex, its index in the input arrays or file. */
PHKS_API const uint32_t *phks_mesh_vertex_origin(const phks_mesh *mesh);
/* Edges with exactly one incident triangle, as 2 * count vertex indices
 * (lower index first, sorted). */
PHKS_API size_t phks_mesh_boundary_edge_count(const phks_mesh *mesh);
PHKS_API const uint32_t *phks_mesh_boundary_edges(const phks_mesh *mesh);
/* Connected components (triangles sharing a vertex are connected), and for
 * each vertex its component, numbered 0.. in order of lowest vertex. */
PHKS_API size_t phks_mesh_component_count(const phks_mesh *mesh);
PHKS_API const uint32_t *phks_mesh_vertex_components(const phks_mesh *mesh);
/* Total surface area, in input units squared. */
PHKS_API double phks_mesh_area(const phks_mesh *mesh);
/* Distances along the surface from vertex `source` to every vertex, in
 * input units, into distance (vertex_count entries): shortest paths over
 * the mesh's edges (a few percent longer than the true geodesic on a
 * regular mesh), with the pieces of a mesh in several pieces joined,
 * vertex to nearest vertex, where they come within the operator's reach
 * (cutoff sqrt(4 tau) in the unit box of options->box; options NULL: the
 * defaults). INFINITY where a piece stays out of reach. The distances
 * PHKS_MATCHING_VERIFIED keeps between feature points, in the unit box.
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, source out of range, bad
 * options), PHKS_ERROR_OUT_OF_MEMORY. Thread-safe. */
PHKS_API phks_status phks_mesh_geodesic_distances(const phks_mesh *mesh,
                                                  const phks_options *options,
                                                  uint32_t source,
                                                  double *distance);

/* =====================================================================
 * Spectrum: the mesh-Laplacian and its smallest eigenpairs
 * =====================================================================
 * The mesh is first scaled to a unit box (options->box). Then, with
 * h = options->tau, A_p a third of the area around vertex p and
 * W(w,p) = exp(-|w-p|^2 / 4h) for |w-p| < cutoff * sqrt(4h):
 *   S = (diag(K 1) - K) / (4 pi h^2),  K_wp = A_w A_p W(w,p)  (w != p),
 *   S phi = lambda M phi,  M = diag(A) (literal) or diag(A) D (random walk).
 * Eigenvalues ascend from 0 (one 0 per cluster of vertices the kernel
 * joins); eigenvectors are M-orthonormal: phi_i^T M phi_j = delta_ij. Each
 * eigenvector's sign is fixed so that its entry of largest magnitude is
 * positive, which makes results repeatable.
 *
 * Large meshes (HKS-simp, the paper's section 4.1 and appendix B): a mesh
 * with more than options->simplify_above vertices (and more than
 * simplify_target) is not solved whole; the operator of a million-vertex
 * mesh would hold 10^4 entries per row. About simplify_target vertices
 * are kept as samples: the local maxima of the heat diagonal at time
 * 2 tau, plus vertices wherever those leave a gap, so that no region or
 * component is left out, evened out around the strongest maxima. Each
 * sample carries the area of the vertices nearest to it, adjusted so that
 * the samples' kernel sums match the mesh's. The operator above is built
 * on the samples with those areas, and its eigenvectors are extended to
 * any vertex w by the Nystrom formula over the samples p within the
 * cut-off (docs/method.md section 11),
 *   phi(w) = sum_p A_p W(w,p) phi(p) / (sum_p A_p W(w,p) - 4 pi h^2 lambda)
 * (random walk: divided by (1 - h lambda) sum_p A_p W(w,p)), which gives
 * back phi(p) at a sample. Time and memory grow linearly with the vertex
 * count: no eigenvector is ever held for every vertex (docs/benchmarks.md
 * has the time and memory measured on large meshes). Such a spectrum's
 * eigenvectors and mass have one entry per sample
 * (phks_spectrum_sample_count and phks_spectrum_sample_vertices say
 * which); phks_spectrum_hks gives every vertex's HKS through the
 * extension. It is an approximation, closest to the exact HKS at large t
 * (docs/method.md section 11; docs/benchmarks.md has its measured mean
 * relative L1 error and correlation against the exact HKS, per time
 * scale). With the literal operator, the exact HKS at small t of a mesh
 * with sharp tips also carries eigenvectors concentrated on single
 * vertices (their HKS grows as 1 / vertex area), which samples cannot
 * carry: there HKS-simp agrees at t = 40 tau and above only.
 */
typedef struct phks_spectrum phks_spectrum;

/* Computes min(options->eigen_count, vertex_count) eigenpairs, or fewer
 * where that count would split a cluster of equal eigenvalues: the last
 * eigenvalue kept is then followed by one that is not equal to it.
 * Eigenvalues are equal when they differ by at most 1e-6 max(|lambda|,
 * 1 / tau) (on PSB meshes the 300th and 301st differ by hundreds of
 * times that, so the count is kept). Within a cluster every solver
 * returns some orthonormal basis, and HKS sums phi_i(x)^2 over the pairs
 * kept, which does not depend on the basis for whole clusters only: an
 * exactly symmetric mesh (a geodesic sphere has 2l + 1 equal values per
 * degree l, the 17th straddling pair 300) would otherwise get HKS that
 * depends on the solver and on the mesh's orientation. The zero
 * eigenvalue's cluster, one per component of the kernel's graph, is known
 * exactly (the constants on each component) and is kept whole even where
 * it holds more than eigen_count pairs (a thousand separate triangles: a
 * thousand pairs). phks_spectrum_count tells how many there are. options
 * may be NULL (defaults). Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL mesh or
 * out, options not from phks_options_init or out of range),
 * PHKS_ERROR_OUT_OF_MEMORY, PHKS_ERROR_CANCELLED, PHKS_ERROR_NO_CONVERGENCE,
 * PHKS_ERROR_SOLVER. Thread-safe (ARPACK calls are serialised inside). */
PHKS_API phks_status phks_spectrum_compute(const phks_mesh *mesh,
                                           const phks_options *options,
                                           phks_spectrum **spectrum);
PHKS_API void phks_spectrum_free(phks_spectrum *spectrum);
/* Number of eigenpairs (0 for NULL). */
PHKS_API size_t phks_spectrum_count(const phks_spectrum *spectrum);
/* The mesh's vertex count: how many values phks_spectrum_hks writes. */
PHKS_API size_t phks_spectrum_vertex_count(const phks_spectrum *spectrum);
/* Entries of each eigenvector and of the mass: the vertex count for an
 * exact spectrum, the number of samples for one made by HKS-simp (0 for
 * NULL). */
PHKS_API size_t phks_spectrum_sample_count(const phks_spectrum *spectrum);
/* The mesh vertex of each entry (sample_count values, ascending); NULL for
 * an exact spectrum, whose entry i is vertex i, and for NULL. */
PHKS_API const uint32_t *phks_spectrum_sample_vertices(
    const phks_spectrum *spectrum);
/* The eigenvalues, ascending, in units of 1 / (unit-box length)^2. */
PHKS_API const double *phks_spectrum_eigenvalues(const phks_spectrum *spectrum);
/* Eigenvector i (sample_count values), or NULL if i is out of range. */
PHKS_API const double *phks_spectrum_eigenvector(const phks_spectrum *spectrum,
                                                 size_t i);
/* The diagonal of M (sample_count values): the inner product under which
 * the eigenvectors are orthonormal. With HKS-simp, a sample's entry is the
 * area it stands for (times its kernel density for the random walk).
 * With PHKS_QUADRATURE_TRIANGLES on a mesh with long triangles the
 * eigenvectors are those of the quadrature points' operator read at the
 * vertices, orthonormal under the points' mass, and a vertex's entry is
 * the mass of the points it interpolates, shared by their barycentric
 * weights (docs/method.md section 13): the total is the same. */
PHKS_API const double *phks_spectrum_mass(const phks_spectrum *spectrum);
/* HKS_t(x) = sum_i exp(-t lambda_i) phi_i(x)^2 for every vertex x, into out
 * (vertex_count values). t is absolute time on the unit-box mesh (t = 5 tau
 * is 0.001 by default), t >= 0. With HKS-simp each call extends every
 * eigenvector to every vertex on the spectrum's options->threads threads,
 * in single precision (1e-6 relative), a cost that grows with the vertex
 * count: call it once per t (docs/benchmarks.md has timings). Errors:
 * PHKS_ERROR_INVALID_ARGUMENT, and
 * with HKS-simp PHKS_ERROR_OUT_OF_MEMORY. Thread-safe. */
PHKS_API phks_status phks_spectrum_hks(const phks_spectrum *spectrum, double t,
                                       double *out);

/* =====================================================================
 * Persistent maxima and segmentation
 * ===================================================================== */
typedef struct phks_maximum {
    uint32_t vertex;     /* vertex of highest f of the central triangle     */
    uint32_t triangle;   /* the central triangle of the region              */
    double value;        /* f at vertex                                     */
    double persistence;  /* its true persistence; INFINITY if never merged  */
} phks_maximum;

/* Region merging (paper section 3.2) of triangles for the vertex function
 * f (vertex_count finite values): every triangle starts as a region; the
 * region of least persistence is merged into its neighbour across its
 * highest boundary edge, until at most max_count regions remain and every
 * region's persistence exceeds threshold (threshold >= 0; zero-persistence
 * regions, which are not maxima, are always merged). Ties are broken by the
 * filtration order (value, then index), so results never vary between runs.
 * Mesh-boundary edges are ignored; a non-manifold edge joins all its
 * triangles.
 * out (room for min(max_count, triangle_count) entries) receives the
 * surviving maxima, most persistent first; *count their number (0 on
 * error). region_of_triangle, if not NULL, receives for each triangle the
 * index in out of its region: the segmentation.
 * Regions merge only across shared edges, so every edge-connected piece
 * keeps one maximum of infinite persistence (two triangles touching at a
 * single vertex are two pieces here, though phks_mesh_component_count
 * counts them as one component). With more pieces than max_count, the
 * max_count whose central triangles come last in the filtration are
 * reported and the other triangles are labelled UINT32_MAX. The vertex of
 * a maximum breaks ties in f by the larger index.
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, max_count 0, negative or NaN
 * threshold), PHKS_ERROR_NON_FINITE (in f), PHKS_ERROR_OUT_OF_MEMORY.
 * No progress reports and no cancellation here: it takes O(T log T) time
 * for T triangles, short next to the spectrum but noticeable on a large
 * mesh, longer for an f with many maxima (docs/benchmarks.md).
 * phks_signature_compute reports progress inside this same computation.
 * Thread-safe. */
PHKS_API phks_status phks_persistent_maxima(const phks_mesh *mesh,
                                            const double *f, size_t max_count,
                                            double threshold, phks_maximum *out,
                                            size_t *count,
                                            uint32_t *region_of_triangle);

/* =====================================================================
 * Signatures
 * =====================================================================
 * A signature is the list of feature points (the persistent maxima of
 * HKS at options->feature_scale) with, for each, the vector of HKS values
 * at options->scales. It remembers the options that shape its numbers;
 * signatures made with different ones refuse to be compared.
 */
typedef struct phks_signature phks_signature;

/* Runs the whole pipeline on mesh. options may be NULL (defaults). Errors:
 * those of phks_spectrum_compute. Thread-safe. */
PHKS_API phks_status phks_signature_compute(const phks_mesh *mesh,
                                            const phks_options *options,
                                            phks_signature **signature);
/* Same from a spectrum already computed for this mesh. Returns
 * PHKS_ERROR_INVALID_ARGUMENT if the spectrum's vertex count is not the
 * mesh's. options must be those the spectrum was computed with. */
PHKS_API phks_status phks_signature_from_spectrum(const phks_mesh *mesh,
                                                  const phks_spectrum *spectrum,
                                                  const phks_options *options,
                                                  phks_signature **signature);
/* The signature whose feature points are the given vertices (count of
 * them, indices of the cleaned mesh, as phks_signature_feature_vertex
 * gives), in the given order, instead of the persistent maxima of HKS:
 * a host's own landmarks, or the maxima of another function. Everything
 * else is made exactly as phks_signature_from_spectrum makes it: each
 * point's vector (HKS at options->scales, scaled by
 * options->hks_scaling), and with PHKS_MATCHING_VERIFIED the spread
 * samples after the points, the distances along the surface between all
 * of them and to the boundary. The vertices phks_signature_from_spectrum
 * picked give back its signature, number for number, apart from the
 * persistence: that of a given point is 0 (no region merging ranked it;
 * as a sample's). (Where two pieces of a mesh touch at a single vertex,
 * each keeps a maximum, and both may be that vertex: such a list, with a
 * vertex twice, is refused here; drop the repeat.) Its feature count is count; it is comparable with
 * every signature made with the same options. options must be those the
 * spectrum was computed with (NULL: the defaults). *signature is the
 * caller's, freed with phks_signature_free; vertices stays the caller's.
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL, the spectrum's vertex count
 * or options not the mesh's and these, count 0 or above
 * options->feature_count, a vertex out of range, a vertex given twice),
 * PHKS_ERROR_OUT_OF_MEMORY, PHKS_ERROR_CANCELLED (options->progress,
 * reported under PHKS_STAGE_PERSISTENCE). Thread-safe. */
PHKS_API phks_status phks_signature_at_vertices(const phks_mesh *mesh,
                                                const phks_spectrum *spectrum,
                                                const phks_options *options,
                                                const uint32_t *vertices,
                                                size_t count,
                                                phks_signature **signature);
PHKS_API void phks_signature_free(phks_signature *signature);

/* Number of feature points (at most options->feature_count; fewer when the
 * HKS has fewer maxima) and the length of each vector (scale_count). */
PHKS_API size_t phks_signature_feature_count(const phks_signature *signature);
PHKS_API size_t phks_signature_vector_length(const phks_signature *signature);
/* Samples: with PHKS_MATCHING_VERIFIED, up to 20 more points spread over
 * the surface (each the farthest, in a straight line, from the features
 * and the samples before it), with their own vectors, after the
 * features: indices feature_count .. feature_count + sample_count - 1 of
 * the accessors below, with persistence 0, positions and vectors rounded
 * to floats. A part of a shape keeps few of its whole's maxima; the
 * samples give its features places on the whole to land on (see
 * phks_match). 0 with NEAREST. */
PHKS_API size_t phks_signature_sample_count(const phks_signature *signature);
/* Feature i: mesh vertex, position in input coordinates (3 doubles into
 * xyz), persistence, and the HKS vector (vector_length values, owned by the
 * signature; HKS at each of options.scales, scaled by options.hks_scaling:
 * logarithms, which may be negative, with the default LOCAL_AREA).
 * Out-of-range i gives UINT32_MAX, PHKS_ERROR_INVALID_ARGUMENT, NaN and
 * NULL respectively. Features come most persistent first. */
PHKS_API uint32_t phks_signature_feature_vertex(const phks_signature *signature,
                                                size_t i);
PHKS_API phks_status phks_signature_feature_position(
    const phks_signature *signature, size_t i, double xyz[3]);
PHKS_API double phks_signature_feature_persistence(
    const phks_signature *signature, size_t i);
PHKS_API const double *phks_signature_feature_vector(
    const phks_signature *signature, size_t i);
/* Copies into *options the options the signature was made with, as
 * resolved (progress and progress_user NULL), so that a new signature can
 * be made comparable with it, or with a database that holds it: a blob
 * decoded from an older version gives the options that version used. A
 * NEAREST signature's blob leaves out local_descriptor and
 * global_descriptor, which NEAREST ignores: decoded, it reads
 * PHKS_LOCAL_DESCRIPTOR_HEAT and PHKS_GLOBAL_DESCRIPTOR_NONE.
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL). Thread-safe. */
PHKS_API phks_status phks_signature_options(const phks_signature *signature,
                                            phks_options *options);

/* Serialisation: a versioned, little-endian, CRC-32-checked byte blob that
 * every later version of the library decodes (docs/formats.md).
 * phks_signature_encoded_size gives the exact blob size. encode writes it
 * into buffer (capacity bytes) and its size into *size; with too small a
 * buffer it returns PHKS_ERROR_BUFFER_TOO_SMALL and still sets *size.
 * decode makes a new signature from a blob; errors PHKS_ERROR_CORRUPT
 * (checksum, impossible field), PHKS_ERROR_TRUNCATED,
 * PHKS_ERROR_UNSUPPORTED_VERSION (a newer format), PHKS_ERROR_OUT_OF_MEMORY.
 * Thread-safe. */
PHKS_API size_t phks_signature_encoded_size(const phks_signature *signature);
PHKS_API phks_status phks_signature_encode(const phks_signature *signature,
                                           void *buffer, size_t capacity,
                                           size_t *size);
PHKS_API phks_status phks_signature_decode(const void *buffer, size_t size,
                                           phks_signature **signature);

/* =====================================================================
 * Scoring and correspondences
 * =====================================================================
 * phks_score(query, entry): lower is more similar. What it measures is the
 * signatures' options.matching (both must have the same):
 *
 * PHKS_MATCHING_VERIFIED (the default):
 *   score(query, entry) = nearest(query, entry) (1 - Q)
 * nearest the formula of NEAREST below and Q in [0, 1] the share of the
 * query's features explained by the largest one-to-one set of
 * correspondences (each feature of the query to one of the entry's
 * features or samples) whose vectors are close and whose distances along
 * the surface agree, up to one scale between the two unit boxes
 * (docs/method.md section 14). 0 for a signature against itself; never
 * above nearest. Asymmetric: the query is the first argument, the entry
 * (a database's) the second; Q is the query's share, so a query that is
 * a part of the entry is not charged for the entry's other points. Q
 * does not change with bending (the distances are intrinsic) nor with
 * the enlargement of a cut shape's unit box up to an octave (every scale
 * between is tried).
 *
 * PHKS_MATCHING_NEAREST (the paper's):
 *   score(A, B) = sum_{a in A} min_{b in B} |a - b|_1
 *               + sum_{b in B} min_{a in A} |a - b|_1
 * over the feature vectors; 0 for identical signatures; symmetric; not a
 * metric.
 *
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL), PHKS_ERROR_INCOMPATIBLE
 * (made with different options), PHKS_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
PHKS_API phks_status phks_score(const phks_signature *query,
                                const phks_signature *entry, double *score);

/* The paper's nearest-L1 score of a and b (the formula of
 * PHKS_MATCHING_NEAREST above) whatever their matching: the fast first
 * stage of a verified query, which needs the feature vectors alone.
 * Errors and thread-safety as phks_score. */
PHKS_API phks_status phks_score_nearest(const phks_signature *a,
                                        const phks_signature *b,
                                        double *score);

/* The same score of two sets of vectors given as plain arrays: a holds
 * a_count vectors and b b_count, each `length` doubles, one after the
 * other (the layout phks_signature_feature_vector returns them in). For
 * hosts that keep the vectors apart from the signatures, such as the
 * compact shortlist keys of the PostgreSQL extension: bit for bit
 * phks_score_nearest of the signatures the vectors came from, but the
 * caller, not the library, must check that they were made with the same
 * options. Nothing is allocated.
 *
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL pointer, a count or length of
 * 0, an entry that is not finite). Thread-safe. */
PHKS_API phks_status phks_score_nearest_vectors(const double *a,
                                                size_t a_count,
                                                const double *b,
                                                size_t b_count, size_t length,
                                                double *score);

typedef struct phks_correspondence {
    uint32_t feature_a;  /* index of a feature of a                         */
    uint32_t feature_b;  /* index of a feature of b                         */
    double distance;     /* L1 distance of their vectors                    */
    uint32_t from_a;     /* 1: a row of feature_a (see phks_match);
                            0: feature_a is the nearest to feature_b        */
    uint32_t verified;   /* 1: the pair is one of the verified set
                            (PHKS_MATCHING_VERIFIED; always 0 with
                            NEAREST). Was `reserved`, always 0, before
                            0.2.0                                          */
} phks_correspondence;

/* The score and its pairs: first one row per feature of a (from_a = 1),
 * then one per feature of b (from_a = 0). A's rows name, with VERIFIED,
 * the feature's verified partner when it has one (verified = 1; a
 * feature or a sample of b: feature_b may be up to feature_count(b) +
 * sample_count(b) - 1), and
 * otherwise, as with NEAREST, its nearest feature of b; b's rows name
 * the nearest feature of a (verified = 1 when that pair is verified).
 * Ties go to the lower index. out needs room for feature_count(a) +
 * feature_count(b) entries (out may be NULL to get only *count and
 * *score). Errors as phks_score, and PHKS_ERROR_BUFFER_TOO_SMALL (then
 * *count is the room needed). Thread-safe. */
PHKS_API phks_status phks_match(const phks_signature *a,
                                const phks_signature *b,
                                phks_correspondence *out, size_t capacity,
                                size_t *count, double *score);

/* A score a reader can weigh: a similarity in [0, 1], 1 for a signature
 * against itself, and how many of the query's features were verified.
 *
 * PHKS_MATCHING_VERIFIED: similarity = Q = 1 - score / nearest, the share
 * of the query the verified set explains (phks_score's Q), with score =
 * phks_score(query, entry) and nearest = phks_score_nearest(query, entry);
 * 1 when nearest is 0. *verified = the rows of phks_match(query, entry)
 * with from_a = 1 and verified = 1, at most
 * phks_signature_feature_count(query).
 *
 * PHKS_MATCHING_NEAREST (nothing is verified: *verified = 0):
 * similarity = exp(-nearest / ((n_q + n_e) L 0.15)), n_q and n_e the
 * feature counts and L the vector length: a mean difference of 0.15 per
 * time scale between a feature and its nearest costs a factor e, as in
 * the verifier (docs/method.md section 14, "What a score means"); 1 for
 * identical vectors. Symmetric.
 *
 * What a similarity says about classes is measured, not promised:
 * docs/retrieval.md, "What a score means". verified may be NULL.
 * Errors as phks_score, and PHKS_ERROR_INVALID_ARGUMENT for a NULL
 * similarity. Costs one phks_score. Thread-safe. Since 0.3.0. */
PHKS_API phks_status phks_similarity(const phks_signature *query,
                                     const phks_signature *entry,
                                     double *similarity, size_t *verified);

/* One point of an entry that a query's feature resembles: its index in
 * the entry (features first, then samples, as phks_correspondence's
 * feature_b numbers them) and the affinity of the two descriptions, in
 * (0, 1], 1 for equal ones. Since 0.3.0. */
typedef struct phks_candidate {
    uint32_t point;
    double affinity;
} phks_candidate;

/* What PHKS_MATCHING_VERIFIED proposes for feature `feature` of a before
 * any geometry is checked: the (up to) k points of b whose local
 * descriptions are nearest to it, most alike first (the lower index on
 * ties), into out, and how many into *count (fewer than k only when b has
 * fewer points or none is alike at all).
 *
 * The description is options.local_descriptor's: with HEAT the feature
 * vectors' steps, exp(-D / (0.15 L)) (docs/method.md section 14); with
 * SPIN the better of that and the spin images', exp(-D_image / 0.1)
 * (section 15). Each point's affinity is its best over the scales of a's
 * unit box against b's that the verification tries (2^(k/4), |k| <= 4).
 * How often a true counterpart is among them is measured in
 * docs/retrieval.md ("Descriptor recall").
 *
 * Errors: PHKS_ERROR_INVALID_ARGUMENT (a NULL argument, feature out of
 * range, k = 0, or signatures not made with PHKS_MATCHING_VERIFIED),
 * PHKS_ERROR_INCOMPATIBLE (different options), PHKS_ERROR_OUT_OF_MEMORY.
 * Thread-safe. */
PHKS_API phks_status phks_candidates(const phks_signature *a, size_t feature,
                                     const phks_signature *b, size_t k,
                                     phks_candidate *out, size_t *count);

/* =====================================================================
 * Shape databases
 * =====================================================================
 * A phks_db is a catalogue of signatures, each with a name (a file name,
 * say) and a class label, stored in one SQLite file (docs/formats.md): every
 * write is one transaction, so a crash, a killed process or a full disk
 * leaves the last committed state readable, and other tools can read the
 * file. The database records the options its signatures were made with
 * (those of the first signature added) and refuses others.
 *
 * Queries scan a packed in-memory copy of every feature vector, on several
 * threads; the copy is refreshed when another process or handle commits.
 *
 * Thread-safety: one handle may be used from many threads at once; queries
 * run in parallel, writes are serialised. Several processes may open the
 * same file; each sees the others' committed writes at its next call.
 *
 * Durability: the file uses SQLite's WAL journal (readers never block the
 * writer) with synchronous=FULL: a write is on disk when its call returns,
 * so a killed process, a system crash or a power loss keeps every
 * committed write. That costs one fsync per transaction: add many
 * signatures with phks_db_add_batch. A call that finds the file locked by
 * another connection's write waits for it up to 5 s, then returns
 * PHKS_ERROR_IO.
 *
 * Any function may also return PHKS_ERROR_CORRUPT when it meets a damaged
 * file, PHKS_ERROR_UNSUPPORTED_VERSION when it meets a signature stored by
 * a newer library in a newer blob format, and PHKS_ERROR_OUT_OF_MEMORY.
 * SQLite allocates through its own allocator, not through
 * phks_set_allocator(). The packed copy takes 8 x scale_count x (feature
 * count rounded up to 8) bytes per entry, 1.9 KB with the default options
 * (1.9 GB for a million entries).
 */
typedef struct phks_db phks_db;

/* Flags for phks_db_open. */
#define PHKS_DB_READONLY 0x1u /* refuse writes; the file must exist      */
#define PHKS_DB_CREATE 0x2u   /* create the file if it does not exist     */

/* Opens (or, with PHKS_DB_CREATE, creates) the database at path; ":memory:"
 * gives a private database in memory (CREATE implied, READONLY refused).
 * An existing empty file is given the schema unless READONLY. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (NULL, "", unknown flags, READONLY with
 * CREATE or with ":memory:"), PHKS_ERROR_IO (missing file
 * without CREATE, unreadable, locked too long), PHKS_ERROR_CORRUPT (not a
 * libphks database, or damaged), PHKS_ERROR_UNSUPPORTED_VERSION (written by
 * a newer format), PHKS_ERROR_OUT_OF_MEMORY. */
PHKS_API phks_status phks_db_open(const char *path, unsigned flags,
                                  phks_db **db);
/* Closes the database and frees the handle; NULL does nothing. No other
 * thread may be using it. */
PHKS_API void phks_db_close(phks_db *db);

/* Adds a signature under name and label (UTF-8, copied; label may be NULL
 * or "" for none, and reads back as "") and sets *id (may be NULL) to its
 * new id, which is never reused. Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL
 * db, name or signature; name or label not valid UTF-8; a signature
 * without features; read-only database), PHKS_ERROR_INCOMPATIBLE (made
 * with other options than the database's), PHKS_ERROR_IO (disk full, file
 * not writable, busy), PHKS_ERROR_OUT_OF_MEMORY. On failure nothing is
 * added. */
PHKS_API phks_status phks_db_add(phks_db *db, const char *name,
                                 const char *label,
                                 const phks_signature *signature, int64_t *id);

typedef struct phks_db_entry {
    const char *name;                 /* required                          */
    const char *label;                /* may be NULL                       */
    const phks_signature *signature;  /* required                          */
} phks_db_entry;

/* Adds count entries in one transaction: all are added or none. ids (may be
 * NULL) receives count ids. Errors as phks_db_add; the message names the
 * index of the entry at fault. */
PHKS_API phks_status phks_db_add_batch(phks_db *db,
                                       const phks_db_entry *entries,
                                       size_t count, int64_t *ids);

/* Removes the entry with this id. Errors: PHKS_ERROR_INVALID_ARGUMENT (NULL,
 * read-only, or no such id), PHKS_ERROR_IO. */
PHKS_API phks_status phks_db_remove(phks_db *db, int64_t id);

/* Number of entries into *count. Errors: PHKS_ERROR_INVALID_ARGUMENT,
 * PHKS_ERROR_IO. */
PHKS_API phks_status phks_db_count(phks_db *db, size_t *count);

/* Up to capacity ids of entries, ascending, starting after after_id (0 for
 * the first page), into ids; *count gets how many were written. Pages
 * through a database of any size. Ids start at 1: a file holding a lower
 * one (only another program can write it) gives PHKS_ERROR_CORRUPT here,
 * in phks_db_count and in phks_db_query. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT, PHKS_ERROR_IO. */
PHKS_API phks_status phks_db_list(phks_db *db, int64_t after_id,
                                  int64_t *ids, size_t capacity,
                                  size_t *count);

/* Entry id: a new signature the caller frees (signature may be NULL), and
 * its name and label copied into caller buffers of name_capacity and
 * label_capacity bytes, NUL-terminated (either buffer may be NULL with
 * capacity 0). Errors: PHKS_ERROR_INVALID_ARGUMENT (no such id),
 * PHKS_ERROR_BUFFER_TOO_SMALL (a string does not fit: nothing is
 * returned), PHKS_ERROR_CORRUPT (the stored blob is damaged),
 * PHKS_ERROR_IO, PHKS_ERROR_OUT_OF_MEMORY. */
PHKS_API phks_status phks_db_get(phks_db *db, int64_t id,
                                 phks_signature **signature, char *name,
                                 size_t name_capacity, char *label,
                                 size_t label_capacity);

/* phks_similarity of query against entry id (a hit of phks_db_query, say),
 * into *similarity and *verified (may be NULL): what a tool shows beside
 * each hit's score. Reads the entry back, so it costs a phks_db_get and a
 * phks_score. Errors as phks_db_get and phks_similarity (a query whose
 * options differ from the database's: PHKS_ERROR_INCOMPATIBLE). Since
 * 0.3.0. */
PHKS_API phks_status phks_db_similarity(phks_db *db,
                                        const phks_signature *query,
                                        int64_t id, double *similarity,
                                        size_t *verified);

/* The longest name or label a hit carries in full; longer ones are cut at
 * a UTF-8 character boundary (phks_db_get returns them whole). */
#define PHKS_DB_TEXT_MAX 255

typedef struct phks_hit {
    int64_t id;
    double score;                        /* phks_score(query, entry)       */
    char name[PHKS_DB_TEXT_MAX + 1];
    char label[PHKS_DB_TEXT_MAX + 1];
} phks_hit;

/* The k best entries for query, best first; ties go to the lower id.
 * hits needs room for k records; *count gets min(k, entries). With
 * PHKS_MATCHING_NEAREST: the k with the lowest phks_score. With VERIFIED,
 * in two stages: the max(k, 32) entries with the lowest
 * phks_score_nearest (ties: lower id), scanned from the packed vectors,
 * then those ranked by phks_score(query, entry), read back with their
 * layouts; the scores are exactly phks_score's (docs/method.md section
 * 14 says what the shortlist costs and loses). The first query
 * of a handle, and the first after another connection committed, loads
 * the packed copy the file keeps beside the entries (a read of its chunks,
 * slower than a scan on a large database: docs/benchmarks.md; a file of an
 * older format, opened read-only, decodes every entry instead); the others
 * only scan it. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (NULL, k = 0), PHKS_ERROR_INCOMPATIBLE (query
 * made with other options than the database's), PHKS_ERROR_IO,
 * PHKS_ERROR_OUT_OF_MEMORY. Many threads may query one handle at once. */
PHKS_API phks_status phks_db_query(phks_db *db, const phks_signature *query,
                                   size_t k, phks_hit *hits, size_t *count);

#ifdef __cplusplus
}
#endif

#endif /* PHKS_H */
