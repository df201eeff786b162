/* test_codec.c - the signature blob: round trip, a byte-exact layout
 * written by hand, and every way a blob can be damaged. */
#include "testutil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static phks_signature *make(size_t count, uint64_t seed)
{
    phks_signature *sig;
    ck_assert_int_eq(phks__signature_alloc(count, 0, 15, &sig), PHKS_OK);
    phks_options_init(&sig->options);
    /* The paper's matching and quadrature: format 2, no layout (format
     * 4's is in test_verify.c). */
    sig->options.matching = PHKS_MATCHING_NEAREST;
    sig->options.quadrature = PHKS_QUADRATURE_VERTICES;
    for (size_t i = 0; i < count; i++) {
        sig->vertex[i] = (uint32_t)(i * 7);
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = test_random(&seed) - 0.5;
        sig->persistence[i] = i == 0 ? INFINITY : test_random(&seed);
        /* signed, as the default logarithms are */
        for (size_t s = 0; s < 15; s++)
            sig->vectors[i * 15 + s] = 100 * test_random(&seed) - 50;
    }
    return sig;
}

/* A VERIFIED signature with its layout, the local descriptor given, and
 * numbers a blob keeps exactly (the samples' and the layout's are f32);
 * spin images (with SPIN) of bytes that differ from point to point. */
static phks_signature *make_verified(size_t count, size_t samples,
                                     int32_t descriptor, uint64_t seed)
{
    phks_signature *sig;
    ck_assert_int_eq(phks__signature_alloc(count, samples, 15, &sig), PHKS_OK);
    phks_options_init(&sig->options);
    sig->options.matching = PHKS_MATCHING_VERIFIED;
    sig->options.quadrature = PHKS_QUADRATURE_VERTICES; /* as make()'s */
    sig->options.local_descriptor = descriptor;
    ck_assert_int_eq(phks__signature_alloc_layout(sig), PHKS_OK);
    size_t points = count + samples;
    for (size_t i = 0; i < points; i++) {
        sig->vertex[i] = (uint32_t)(i * 7);
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = (float)(test_random(&seed) - 0.5);
        sig->persistence[i] = i >= count ? 0
                              : i == 0   ? INFINITY
                                         : test_random(&seed);
        for (size_t s = 0; s < 15; s++)
            sig->vectors[i * 15 + s] = (float)(100 * test_random(&seed) - 50);
        sig->boundary[i] = (float)test_random(&seed);
    }
    for (size_t k = 0; k < phks__pair_count(points); k++)
        sig->geodesic[k] = (float)test_random(&seed);
    if (descriptor == PHKS_LOCAL_DESCRIPTOR_SPIN) {
        ck_assert_ptr_nonnull(sig->spin);
        sig->unit_scale = 0.25 + test_random(&seed);
        for (size_t b = 0; b < points * PHKS__SPIN_BYTES; b++)
            sig->spin[b] = (uint8_t)(1 + (b * 37 + b / PHKS__SPIN_BYTES) % 255);
    } else {
        ck_assert_ptr_null(sig->spin);
    }
    return sig;
}

/* make_verified's signature made with PHKS_GLOBAL_DESCRIPTOR_D2, its
 * shape distribution of bytes that differ from bin to bin, set here as
 * the computation would: the codec does not depend on it. */
static phks_signature *make_d2(size_t count, size_t samples,
                               int32_t descriptor, uint64_t seed)
{
    phks_signature *sig = make_verified(count, samples, descriptor, seed);
    sig->options.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    sig->has_shape = true;
    for (size_t b = 0; b < PHKS__SHAPE_BINS; b++)
        sig->shape[b] = (uint8_t)(200 - 5 * b + seed);
    return sig;
}

/* Rewrites the CRC-32 at the end of a hand-edited blob. */
static void fix_crc(unsigned char *blob, size_t size)
{
    uint32_t crc = phks__crc32(blob, size - 4);
    for (int i = 0; i < 4; i++)
        blob[size - 4 + i] = (unsigned char)(crc >> (8 * i));
}

static unsigned char *encode(const phks_signature *sig, size_t *size)
{
    size_t need = phks_signature_encoded_size(sig);
    unsigned char *blob = malloc(need);
    ck_assert_int_eq(phks_signature_encode(sig, blob, need, size), PHKS_OK);
    ck_assert_uint_eq(*size, need);
    return blob;
}

START_TEST(round_trip_is_exact)
{
    phks_signature *sig = make(15, 1);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(blob, size, &back), PHKS_OK);
    ck_assert_uint_eq(back->count, 15);
    ck_assert_mem_eq(back->vertex, sig->vertex, 15 * sizeof(uint32_t));
    ck_assert_mem_eq(back->position, sig->position, 45 * sizeof(double));
    ck_assert_mem_eq(back->persistence, sig->persistence, 15 * sizeof(double));
    ck_assert_mem_eq(back->vectors, sig->vectors, 225 * sizeof(double));
    ck_assert(phks__options_comparable(&back->options, &sig->options));
    double score;
    ck_assert_int_eq(phks_score(sig, back, &score), PHKS_OK);
    ck_assert_double_eq(score, 0);
    phks_signature_free(back);
    phks_signature_free(sig);
    free(blob);
}
END_TEST

/* The first bytes, laid out by hand from docs/formats.md: the blob is
 * little-endian on every host. */
START_TEST(layout_is_little_endian)
{
    phks_signature *sig = make(1, 2);
    sig->options.boundary_margin = 1.5;
    sig->options.hks_scaling = PHKS_HKS_SCALING_MEAN;
    size_t size;
    unsigned char *blob = encode(sig, &size);
    const unsigned char head[8] = {'P', 'H', 'K', 'S', 2, 0, 0, 0};
    ck_assert_mem_eq(blob, head, 8);
    /* tau = 0.0002 = 0x3F2A36E2EB1C432D */
    const unsigned char tau[8] = {0x2D, 0x43, 0x1C, 0xEB, 0xE2, 0x36, 0x2A, 0x3F};
    ck_assert_mem_eq(blob + 8, tau, 8);
    /* eigen_count 300 = 0x12C at offset 24 */
    const unsigned char k[4] = {0x2C, 0x01, 0, 0};
    ck_assert_mem_eq(blob + 24, k, 4);
    /* boundary_margin 1.5 = 0x3FF8000000000000 at 52, hks_scaling 1 at 60 */
    const unsigned char margin[12] = {0, 0, 0, 0, 0, 0, 0xF8, 0x3F, 1, 0, 0, 0};
    ck_assert_mem_eq(blob + 52, margin, 12);
    /* header 64, scales 120, count 4, one feature 4 + 24 + 8 + 120, crc 4 */
    ck_assert_uint_eq(size, 64 + 15 * 8 + 4 + (4 + 32 + 15 * 8) + 4);
    phks_signature_free(sig);
    free(blob);
}
END_TEST

/* A format-1 blob (0.1.0 wrote them; no margin and scaling fields) still
 * decodes, as made with the paper's behaviour for those fields. */
START_TEST(format_1_still_reads)
{
    phks_signature *sig = make(2, 6);
    sig->options.boundary_margin = 0;
    sig->options.hks_scaling = PHKS_HKS_SCALING_NONE;
    size_t size;
    unsigned char *blob = encode(sig, &size);
    size_t old_size = size - 12;
    unsigned char *old = malloc(old_size);
    memcpy(old, blob, 52);
    memcpy(old + 52, blob + 64, size - 64);
    old[4] = 1;
    uint32_t crc = phks__crc32(old, old_size - 4);
    for (int i = 0; i < 4; i++)
        old[old_size - 4 + i] = (unsigned char)(crc >> (8 * i));
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(old, old_size, &back), PHKS_OK);
    phks_options made;
    ck_assert_int_eq(phks_signature_options(back, &made), PHKS_OK);
    ck_assert_double_eq(made.boundary_margin, 0);
    ck_assert_int_eq(made.hks_scaling, PHKS_HKS_SCALING_NONE);
    ck_assert_int_eq(phks_signature_options(NULL, &made),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_signature_options(back, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert(phks__options_comparable(&back->options, &sig->options));
    ck_assert_mem_eq(back->vectors, sig->vectors, 30 * sizeof(double));
    phks_signature_free(back);
    phks_signature_free(sig);
    free(blob);
    free(old);
}
END_TEST

/* Format 3: written only with PHKS_QUADRATURE_TRIANGLES, its field at
 * offset 64 and the rest 4 bytes later; without the option the same bytes
 * as format 2, which decodes with quadrature 0 and scores against a new
 * signature made without it. */
START_TEST(format_3_only_with_quadrature)
{
    phks_signature *sig = make(1, 2);
    size_t size;
    unsigned char *two = encode(sig, &size);
    ck_assert_uint_eq(two[4], 2);
    ck_assert_uint_eq(size, 64 + 15 * 8 + 4 + (4 + 32 + 15 * 8) + 4);
    sig->options.quadrature = PHKS_QUADRATURE_TRIANGLES;
    size_t size3;
    unsigned char *three = encode(sig, &size3);
    ck_assert_uint_eq(size3, size + 4);
    const unsigned char head[8] = {'P', 'H', 'K', 'S', 3, 0, 0, 0};
    ck_assert_mem_eq(three, head, 8);
    ck_assert_mem_eq(three + 8, two + 8, 56);
    const unsigned char quadrature[4] = {1, 0, 0, 0};
    ck_assert_mem_eq(three + 64, quadrature, 4);
    ck_assert_mem_eq(three + 68, two + 64, size - 64 - 4);
    phks_signature *back3, *back2;
    ck_assert_int_eq(phks_signature_decode(three, size3, &back3), PHKS_OK);
    ck_assert_int_eq(phks_signature_decode(two, size, &back2), PHKS_OK);
    ck_assert_int_eq(back3->options.quadrature, PHKS_QUADRATURE_TRIANGLES);
    ck_assert_int_eq(back2->options.quadrature, PHKS_QUADRATURE_VERTICES);
    ck_assert(phks__options_comparable(&back3->options, &sig->options));
    double score;
    ck_assert_int_eq(phks_score(back2, back3, &score), PHKS_ERROR_INCOMPATIBLE);
    sig->options.quadrature = PHKS_QUADRATURE_VERTICES;
    ck_assert_int_eq(phks_score(back2, sig, &score), PHKS_OK);
    ck_assert_double_eq(score, 0);
    /* an unknown quadrature is refused like any impossible option */
    three[64] = 7;
    uint32_t crc = phks__crc32(three, size3 - 4);
    for (int i = 0; i < 4; i++)
        three[size3 - 4 + i] = (unsigned char)(crc >> (8 * i));
    phks_signature *bad = (phks_signature *)1;
    ck_assert_int_eq(phks_signature_decode(three, size3, &bad), PHKS_ERROR_CORRUPT);
    ck_assert_ptr_null(bad);
    phks_signature_free(back2);
    phks_signature_free(back3);
    phks_signature_free(sig);
    free(two);
    free(three);
}
END_TEST

START_TEST(small_buffer_reports_the_size)
{
    phks_signature *sig = make(3, 3);
    size_t size = 0;
    unsigned char small[16];
    ck_assert_int_eq(phks_signature_encode(sig, small, sizeof small, &size),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    ck_assert_uint_eq(size, phks_signature_encoded_size(sig));
    ck_assert_int_eq(phks_signature_encode(sig, NULL, 0, &size),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    phks_signature_free(sig);
}
END_TEST

/* Flipping any single bit anywhere is caught (checksum, magic or layout);
 * cutting the blob anywhere is caught; nothing leaks, nothing crashes. */
START_TEST(every_damage_is_refused)
{
    phks_signature *sig = make(4, 4);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    unsigned char *copy = malloc(size);
    phks_signature *out;
    for (size_t byte = 0; byte < size; byte++)
        for (int bit = 0; bit < 8; bit++) {
            memcpy(copy, blob, size);
            copy[byte] ^= (unsigned char)(1u << bit);
            out = (phks_signature *)1;
            phks_status st = phks_signature_decode(copy, size, &out);
            ck_assert_int_ne(st, PHKS_OK);
            ck_assert_ptr_null(out);
        }
    for (size_t len = 0; len < size; len++) {
        phks_status st = phks_signature_decode(blob, len, &out);
        ck_assert(st == PHKS_ERROR_TRUNCATED || st == PHKS_ERROR_CORRUPT);
    }
    memcpy(copy, blob, size);
    copy[4] = 7; /* a newer format */
    ck_assert_int_eq(phks_signature_decode(copy, size, &out),
                     PHKS_ERROR_UNSUPPORTED_VERSION);
    ck_assert_int_eq(phks_signature_decode(NULL, size, &out),
                     PHKS_ERROR_INVALID_ARGUMENT);
    phks_signature_free(sig);
    free(blob);
    free(copy);
}
END_TEST

/* Too short for any format's header and checksum (56 bytes): truncated,
 * whatever the format field holds, not "newer" (a user's "PHKSxxxxxxxx"
 * read as format 30840); one that holds them with a newer format number is
 * still refused as newer, as docs/formats.md promises. */
START_TEST(short_blob_is_truncated_whatever_its_format)
{
    phks_signature *out;
    static const char garbage[] = "PHKSxxxxxxxx";
    ck_assert_int_eq(phks_signature_decode(garbage, 12, &out),
                     PHKS_ERROR_TRUNCATED);
    ck_assert_str_eq(phks_last_error_message(),
                     "signature blob: 12 bytes, shorter than any format's "
                     "header and checksum (56 bytes)");
    phks_signature *sig = make(3, 8);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    blob[4] = 0xff; /* format 65535 */
    blob[5] = 0xff;
    for (size_t len = 8; len < 56; len++)
        ck_assert_int_eq(phks_signature_decode(blob, len, &out),
                         PHKS_ERROR_TRUNCATED);
    ck_assert_int_eq(phks_signature_decode(blob, 56, &out),
                     PHKS_ERROR_UNSUPPORTED_VERSION);
    ck_assert_int_eq(phks_signature_decode(blob, size, &out),
                     PHKS_ERROR_UNSUPPORTED_VERSION);
    ck_assert_ptr_null(out);
    phks_signature_free(sig);
    free(blob);
}
END_TEST

/* A blob with a valid checksum but impossible numbers (made by hand, as a
 * hostile writer would) is still refused. */
START_TEST(valid_checksum_impossible_numbers)
{
    phks_signature *sig = make(2, 5);
    sig->vectors[3] = NAN;
    size_t size;
    unsigned char *blob = encode(sig, &size);
    phks_signature *out;
    ck_assert_int_eq(phks_signature_decode(blob, size, &out), PHKS_ERROR_CORRUPT);
    free(blob);
    sig->vectors[3] = 1;
    sig->options.tau = -1;
    blob = encode(sig, &size);
    ck_assert_int_eq(phks_signature_decode(blob, size, &out), PHKS_ERROR_CORRUPT);
    free(blob);
    phks_signature_free(sig);
}
END_TEST

START_TEST(incompatible_options_refuse_to_score)
{
    phks_signature *a = make(3, 6), *b = make(3, 7);
    double score;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    /* Each refusal names the option and both values. */
    b->options.scales[14] = 999;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "scales[14] 1000 against 999"));
    b->options.scales[14] = a->options.scales[14];
    b->options.operator_kind = PHKS_OPERATOR_LITERAL;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "operator_kind"));
    b->options.operator_kind = a->options.operator_kind;
    b->options.boundary_margin = 0;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "boundary_margin 2 against 0"));
    b->options.boundary_margin = a->options.boundary_margin;
    b->options.hks_scaling = PHKS_HKS_SCALING_MEAN;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "hks_scaling"));
    b->options.hks_scaling = a->options.hks_scaling;
    b->options.simplify_above = 7; /* does not change what is compared */
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    b->options.operator_kind = a->options.operator_kind;
    b->options.solver = PHKS_SOLVER_ARPACK; /* does not change the numbers */
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

/* Format 5: a VERIFIED signature with spin images keeps them, byte for
 * byte, after its layout; its local descriptor sits at offset 72. */
START_TEST(format_5_round_trip_keeps_the_spin_images)
{
    const size_t count = 4, samples = 3, points = count + samples;
    phks_signature *sig =
        make_verified(count, samples, PHKS_LOCAL_DESCRIPTOR_SPIN, 11);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    const unsigned char head[8] = {'P', 'H', 'K', 'S', 5, 0, 0, 0};
    ck_assert_mem_eq(blob, head, 8);
    const unsigned char descriptor[4] = {1, 0, 0, 0};
    ck_assert_mem_eq(blob + 72, descriptor, 4);
    /* header 76, scales, features, samples, boundary, geodesic, images */
    size_t layout = 4 + samples * (4 + 12 + 4 * 15) + 4 * points +
                    4 * phks__pair_count(points);
    ck_assert_uint_eq(size, 76 + 15 * 8 + 4 + count * (4 + 32 + 15 * 8) +
                                layout + 8 + points * PHKS__SPIN_BYTES + 4);
    ck_assert_mem_eq(blob + size - 4 - points * PHKS__SPIN_BYTES, sig->spin,
                     points * PHKS__SPIN_BYTES);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(blob, size, &back), PHKS_OK);
    ck_assert_int_eq(back->options.local_descriptor,
                     PHKS_LOCAL_DESCRIPTOR_SPIN);
    ck_assert_uint_eq(back->samples, samples);
    ck_assert(back->unit_scale == sig->unit_scale);
    ck_assert_ptr_nonnull(back->spin);
    ck_assert_mem_eq(back->spin, sig->spin, points * PHKS__SPIN_BYTES);
    ck_assert_mem_eq(back->vectors, sig->vectors,
                     points * 15 * sizeof(double));
    ck_assert_mem_eq(back->geodesic, sig->geodesic,
                     phks__pair_count(points) * sizeof(float));
    size_t again;
    unsigned char *twice = encode(back, &again);
    ck_assert_uint_eq(again, size);
    ck_assert_mem_eq(twice, blob, size);
    phks_signature_free(back);
    phks_signature_free(sig);
    free(blob);
    free(twice);
}
END_TEST

/* HEAT keeps format 4's bytes: the format-5 blob of the same signature
 * less the local descriptor's field and the images, its checksum made
 * again. It decodes with HEAT, as does every older blob. */
START_TEST(heat_keeps_format_4_bytes)
{
    const size_t count = 3, samples = 2, points = count + samples;
    phks_signature *spin =
        make_verified(count, samples, PHKS_LOCAL_DESCRIPTOR_SPIN, 12);
    phks_signature *heat =
        make_verified(count, samples, PHKS_LOCAL_DESCRIPTOR_HEAT, 12);
    size_t size5, size4;
    unsigned char *five = encode(spin, &size5);
    unsigned char *four = encode(heat, &size4);
    ck_assert_uint_eq(four[4], 4);
    ck_assert_uint_eq(size5, size4 + 4 + 8 + points * PHKS__SPIN_BYTES);
    unsigned char *cut = malloc(size4);
    memcpy(cut, five, 72);
    memcpy(cut + 72, five + 76, size4 - 72 - 4);
    cut[4] = 4;
    fix_crc(cut, size4);
    ck_assert_mem_eq(cut, four, size4);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(four, size4, &back), PHKS_OK);
    ck_assert_int_eq(back->options.local_descriptor,
                     PHKS_LOCAL_DESCRIPTOR_HEAT);
    ck_assert_ptr_null(back->spin);
    phks_signature_free(back);
    /* Format 2 (NEAREST) blobs decode with HEAT too. */
    phks_signature *near = make(2, 3);
    size_t size2;
    unsigned char *two = encode(near, &size2);
    ck_assert_int_eq(phks_signature_decode(two, size2, &back), PHKS_OK);
    ck_assert_int_eq(back->options.local_descriptor,
                     PHKS_LOCAL_DESCRIPTOR_HEAT);
    phks_signature_free(back);
    free(two);
    phks_signature_free(near);
    phks_signature_free(spin);
    phks_signature_free(heat);
    free(five);
    free(four);
    free(cut);
}
END_TEST

/* NEAREST ignores the local descriptor: its blob leaves it out, so either
 * value gives the same format-2 bytes. */
START_TEST(nearest_blobs_leave_the_descriptor_out)
{
    phks_signature *sig = make(3, 13);
    sig->options.local_descriptor = PHKS_LOCAL_DESCRIPTOR_SPIN;
    size_t size_spin, size_heat;
    unsigned char *with_spin = encode(sig, &size_spin);
    sig->options.local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    unsigned char *with_heat = encode(sig, &size_heat);
    ck_assert_uint_eq(with_spin[4], 2);
    ck_assert_uint_eq(size_spin, size_heat);
    ck_assert_mem_eq(with_spin, with_heat, size_spin);
    phks_signature_free(sig);
    free(with_spin);
    free(with_heat);
}
END_TEST

/* Every blob cut short of `size` bytes is refused as truncated or
 * corrupt, and so is the whole blob with one bit flipped in every
 * `stride`-th byte (bit byte % 8); the output stays NULL. */
static void assert_cuts_and_flips_refused(const unsigned char *blob,
                                          size_t size, size_t stride)
{
    unsigned char *copy = malloc(size);
    ck_assert_ptr_nonnull(copy);
    phks_signature *out;
    for (size_t len = 0; len < size; len++) {
        out = (phks_signature *)1;
        phks_status st = phks_signature_decode(blob, len, &out);
        ck_assert_msg(st == PHKS_ERROR_TRUNCATED || st == PHKS_ERROR_CORRUPT,
                      "%zu bytes: %d", len, (int)st);
        ck_assert_ptr_null(out);
    }
    for (size_t byte = 0; byte < size; byte += stride) {
        memcpy(copy, blob, size);
        copy[byte] ^= (unsigned char)(1u << (byte % 8));
        out = (phks_signature *)1;
        ck_assert_int_ne(phks_signature_decode(copy, size, &out), PHKS_OK);
        ck_assert_ptr_null(out);
    }
    free(copy);
}

/* A format-5 blob cut anywhere, or with its images' last byte cut and
 * the checksum made again, or with any bit flipped, is refused, its
 * output NULL; an unknown local descriptor is an impossible option. */
START_TEST(format_5_damage_is_refused)
{
    phks_signature *sig = make_verified(2, 1, PHKS_LOCAL_DESCRIPTOR_SPIN, 14);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    phks_signature *out;
    assert_cuts_and_flips_refused(blob, size, 3);
    unsigned char *copy = malloc(size);
    memcpy(copy, blob, size);
    /* One byte fewer of images, a valid checksum over what is left. */
    memmove(copy + size - 5, copy + size - 4, 4);
    fix_crc(copy, size - 1);
    ck_assert_int_eq(phks_signature_decode(copy, size - 1, &out),
                     PHKS_ERROR_TRUNCATED);
    ck_assert_ptr_null(out);
    /* Local descriptor 7, checksum fixed: no images expected, and refused
     * as a bad option (the bytes are those of a HEAT blob's size). */
    phks_signature *heat =
        make_verified(2, 1, PHKS_LOCAL_DESCRIPTOR_HEAT, 14);
    heat->options.local_descriptor = 7;
    size_t size7;
    unsigned char *seven = encode(heat, &size7);
    ck_assert_uint_eq(seven[4], 5);
    ck_assert_int_eq(phks_signature_decode(seven, size7, &out),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "unknown local_descriptor 7"));
    ck_assert_ptr_null(out);
    phks_signature_free(heat);
    free(seven);
    /* A spin signature that lost its images cannot be encoded. */
    free(sig->spin);
    sig->spin = NULL;
    ck_assert_int_eq(phks_signature_encode(sig, copy, size, &size),
                     PHKS_ERROR_INVALID_ARGUMENT);
    phks_signature_free(sig);
    free(blob);
    free(copy);
}
END_TEST

/* x against y does not score, nor y against x by the paper's score,
 * each message saying which option and values: `forward`, `backward`. */
static void refused_both_ways(const phks_signature *x,
                              const phks_signature *y, const char *forward,
                              const char *backward)
{
    double score;
    ck_assert_int_eq(phks_score(x, y, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), forward));
    ck_assert_int_eq(phks_score_nearest(y, x, &score),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), backward));
}

/* Two VERIFIED signatures of other local descriptors do not score, and
 * the message names the option and both values; two NEAREST ones do,
 * whatever their local descriptors. */
START_TEST(local_descriptors_compare_only_when_verified)
{
    phks_signature *heat = make_verified(3, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 15);
    phks_signature *spin = make_verified(3, 2, PHKS_LOCAL_DESCRIPTOR_SPIN, 16);
    double score;
    refused_both_ways(heat, spin, "local_descriptor heat against spin",
                      "local_descriptor spin against heat");
    char detail[64];
    ck_assert_int_eq(phks_options_compare(&heat->options, &spin->options,
                                          PHKS_SPELLING_CLI, detail,
                                          sizeof detail),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_str_eq(detail, "local-descriptor heat against spin");
    phks_signature *a = make(3, 17), *b = make(3, 18);
    a->options.local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    b->options.local_descriptor = PHKS_LOCAL_DESCRIPTOR_SPIN;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    ck_assert_int_eq(phks_options_compare(&a->options, &b->options,
                                          PHKS_SPELLING_C, NULL, 0),
                     PHKS_OK);
    /* NEAREST against VERIFIED: matching tells them apart, whatever the
     * descriptors. */
    ck_assert_int_eq(phks_score(a, heat, &score), PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "matching nearest against verified"));
    phks_signature_free(a);
    phks_signature_free(b);
    phks_signature_free(heat);
    phks_signature_free(spin);
}
END_TEST

/* Format 6: a VERIFIED signature with the shape distribution keeps its
 * PHKS__SHAPE_BINS bytes, bit for bit, after the layout and the spin
 * images; the global descriptor sits at offset 76, after the local one,
 * and the blob is the format-5 one plus those 4 and 32 bytes. */
START_TEST(format_6_round_trip_keeps_the_shape_distribution)
{
    const size_t count = 4, samples = 3, points = count + samples;
    phks_signature *sig = make_d2(count, samples, PHKS_LOCAL_DESCRIPTOR_SPIN, 21);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    const unsigned char head[8] = {'P', 'H', 'K', 'S', 6, 0, 0, 0};
    ck_assert_mem_eq(blob, head, 8);
    const unsigned char descriptors[8] = {1, 0, 0, 0, 1, 0, 0, 0};
    ck_assert_mem_eq(blob + 72, descriptors, 8);
    sig->options.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_NONE;
    size_t size5;
    unsigned char *five = encode(sig, &size5);
    sig->options.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    ck_assert_uint_eq(five[4], 5);
    ck_assert_uint_eq(size, size5 + 4 + PHKS__SHAPE_BINS);
    ck_assert_mem_eq(blob + size - 4 - PHKS__SHAPE_BINS, sig->shape,
                     PHKS__SHAPE_BINS);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(blob, size, &back), PHKS_OK);
    ck_assert_int_eq(back->options.global_descriptor,
                     PHKS_GLOBAL_DESCRIPTOR_D2);
    ck_assert_int_eq(back->options.local_descriptor,
                     PHKS_LOCAL_DESCRIPTOR_SPIN);
    ck_assert(back->has_shape);
    ck_assert_mem_eq(back->shape, sig->shape, PHKS__SHAPE_BINS);
    ck_assert_mem_eq(back->spin, sig->spin, points * PHKS__SPIN_BYTES);
    ck_assert_mem_eq(back->geodesic, sig->geodesic,
                     phks__pair_count(points) * sizeof(float));
    size_t again;
    unsigned char *twice = encode(back, &again);
    ck_assert_uint_eq(again, size);
    ck_assert_mem_eq(twice, blob, size);
    phks_signature_free(back);
    phks_signature_free(sig);
    free(blob);
    free(five);
    free(twice);
}
END_TEST

/* With HEAT, format 6 still holds the local descriptor (0): the format-4
 * blob plus the two descriptors' 8 bytes and the distribution's 32. */
START_TEST(format_6_holds_heat_too)
{
    phks_signature *d2 = make_d2(3, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 22);
    phks_signature *none = make_verified(3, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 22);
    size_t size6, size4;
    unsigned char *six = encode(d2, &size6);
    unsigned char *four = encode(none, &size4);
    ck_assert_uint_eq(six[4], 6);
    ck_assert_uint_eq(four[4], 4);
    ck_assert_uint_eq(size6, size4 + 8 + PHKS__SHAPE_BINS);
    const unsigned char descriptors[8] = {0, 0, 0, 0, 1, 0, 0, 0};
    ck_assert_mem_eq(six + 72, descriptors, 8);
    /* Less the two fields and the distribution, the bytes are format 4's. */
    ck_assert_mem_eq(six + 8, four + 8, 64);
    ck_assert_mem_eq(six + 80, four + 72, size4 - 72 - 4);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(six, size6, &back), PHKS_OK);
    ck_assert_int_eq(back->options.local_descriptor,
                     PHKS_LOCAL_DESCRIPTOR_HEAT);
    ck_assert_ptr_null(back->spin);
    ck_assert(back->has_shape);
    ck_assert_mem_eq(back->shape, d2->shape, PHKS__SHAPE_BINS);
    phks_signature_free(back);
    phks_signature_free(d2);
    phks_signature_free(none);
    free(six);
    free(four);
}
END_TEST

/* NONE keeps the older formats' bytes, and every older blob decodes with
 * NONE and no distribution; a format-6 blob that holds NONE (no writer of
 * this library makes one) decodes too and is written back in format 5. */
START_TEST(none_keeps_older_formats)
{
    phks_signature *spin = make_verified(2, 2, PHKS_LOCAL_DESCRIPTOR_SPIN, 23);
    phks_signature *heat = make_verified(2, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 23);
    phks_signature *near = make(2, 23);
    phks_signature *sigs[3] = {spin, heat, near};
    const unsigned formats[3] = {5, 4, 2};
    size_t size;
    for (int k = 0; k < 3; k++) {
        unsigned char *blob = encode(sigs[k], &size);
        ck_assert_uint_eq(blob[4], formats[k]);
        phks_signature *back;
        ck_assert_int_eq(phks_signature_decode(blob, size, &back), PHKS_OK);
        ck_assert_int_eq(back->options.global_descriptor,
                         PHKS_GLOBAL_DESCRIPTOR_NONE);
        ck_assert(!back->has_shape);
        phks_signature_free(back);
        free(blob);
    }
    unsigned char *five = encode(spin, &size);
    unsigned char *six = calloc(1, size + 4);
    memcpy(six, five, 76);
    memcpy(six + 80, five + 76, size - 76);
    six[4] = 6;
    fix_crc(six, size + 4);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(six, size + 4, &back), PHKS_OK);
    ck_assert_int_eq(back->options.global_descriptor,
                     PHKS_GLOBAL_DESCRIPTOR_NONE);
    ck_assert(!back->has_shape);
    size_t again;
    unsigned char *twice = encode(back, &again);
    ck_assert_uint_eq(again, size);
    ck_assert_mem_eq(twice, five, size);
    phks_signature_free(back);
    free(twice);
    free(six);
    free(five);
    phks_signature_free(spin);
    phks_signature_free(heat);
    phks_signature_free(near);
}
END_TEST

/* NEAREST ignores the global descriptor: its blob leaves it out (format
 * 2, the same bytes as with NONE) and decodes with NONE. */
START_TEST(nearest_blobs_leave_the_global_descriptor_out)
{
    phks_signature *sig = make(3, 24);
    size_t size_none, size_d2;
    unsigned char *with_none = encode(sig, &size_none);
    sig->options.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    unsigned char *with_d2 = encode(sig, &size_d2);
    ck_assert_uint_eq(with_d2[4], 2);
    ck_assert_uint_eq(size_d2, size_none);
    ck_assert_mem_eq(with_d2, with_none, size_none);
    phks_signature *back;
    ck_assert_int_eq(phks_signature_decode(with_d2, size_d2, &back), PHKS_OK);
    ck_assert_int_eq(back->options.global_descriptor,
                     PHKS_GLOBAL_DESCRIPTOR_NONE);
    ck_assert(!back->has_shape);
    phks_signature_free(back);
    phks_signature_free(sig);
    free(with_none);
    free(with_d2);
}
END_TEST

/* A format-6 blob cut anywhere, one byte short of its distribution or
 * one byte over (checksums made again), or with any bit flipped, is
 * refused, its output NULL; an unknown global descriptor is an impossible
 * option; a D2 signature without its distribution cannot be encoded. */
START_TEST(format_6_damage_is_refused)
{
    phks_signature *sig = make_d2(2, 1, PHKS_LOCAL_DESCRIPTOR_HEAT, 25);
    size_t size;
    unsigned char *blob = encode(sig, &size);
    phks_signature *out;
    assert_cuts_and_flips_refused(blob, size, 1);
    unsigned char *copy = malloc(size + 1);
    memcpy(copy, blob, size);
    memmove(copy + size - 5, copy + size - 4, 4);
    fix_crc(copy, size - 1);
    ck_assert_int_eq(phks_signature_decode(copy, size - 1, &out),
                     PHKS_ERROR_TRUNCATED);
    ck_assert_ptr_null(out);
    memcpy(copy, blob, size - 4);
    copy[size - 4] = 0x55;
    fix_crc(copy, size + 1);
    ck_assert_int_eq(phks_signature_decode(copy, size + 1, &out),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_null(out);
    /* Global descriptor 2, checksum fixed: no distribution expected, and
     * refused as a bad option. */
    phks_signature *two = make_verified(2, 1, PHKS_LOCAL_DESCRIPTOR_HEAT, 25);
    two->options.global_descriptor = 2;
    size_t size2;
    unsigned char *blob2 = encode(two, &size2);
    ck_assert_uint_eq(blob2[4], 6);
    ck_assert_uint_eq(size2, size - PHKS__SHAPE_BINS);
    ck_assert_int_eq(phks_signature_decode(blob2, size2, &out),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "unknown global_descriptor 2"));
    ck_assert_ptr_null(out);
    phks_signature_free(two);
    free(blob2);
    sig->has_shape = false;
    ck_assert_int_eq(phks_signature_encode(sig, copy, size, &size),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_str_eq(phks_last_error_message(),
                     "phks_signature_encode: a D2 signature without its "
                     "shape distribution");
    phks_signature_free(sig);
    free(blob);
    free(copy);
}
END_TEST

/* Two VERIFIED signatures of other global descriptors do not score, the
 * message naming the option and both values; two NEAREST ones do. */
START_TEST(global_descriptors_compare_only_when_verified)
{
    phks_signature *none = make_verified(3, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 26);
    phks_signature *d2 = make_d2(3, 2, PHKS_LOCAL_DESCRIPTOR_HEAT, 27);
    double score;
    refused_both_ways(none, d2, "global_descriptor none against d2",
                      "global_descriptor d2 against none");
    phks_signature *a = make(3, 28), *b = make(3, 29);
    b->options.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    phks_signature_free(a);
    phks_signature_free(b);
    phks_signature_free(none);
    phks_signature_free(d2);
}
END_TEST

/* Score and match against a brute-force evaluation of docs/method.md
 * section 10. */
START_TEST(score_is_the_symmetric_nearest_sum)
{
    phks_signature *a = make(5, 8), *b = make(9, 9);
    double expect = 0;
    for (int side = 0; side < 2; side++) {
        phks_signature *x = side ? b : a, *y = side ? a : b;
        for (size_t i = 0; i < x->count; i++) {
            double best = INFINITY;
            for (size_t j = 0; j < y->count; j++) {
                double d = 0;
                for (int s = 0; s < 15; s++)
                    d += fabs(x->vectors[i * 15 + s] - y->vectors[j * 15 + s]);
                best = fmin(best, d);
            }
            expect += best;
        }
    }
    double ab, ba;
    ck_assert_int_eq(phks_score(a, b, &ab), PHKS_OK);
    ck_assert_int_eq(phks_score(b, a, &ba), PHKS_OK);
    ck_assert_double_eq_tol(ab, expect, 1e-9 * expect);
    ck_assert_double_eq(ab, ba);
    phks_correspondence c[14];
    size_t count;
    double score;
    ck_assert_int_eq(phks_match(a, b, c, 14, &count, &score), PHKS_OK);
    ck_assert_uint_eq(count, 14);
    ck_assert_double_eq(score, ab);
    double sum = 0;
    for (size_t i = 0; i < count; i++) {
        ck_assert_uint_eq(c[i].from_a, i < 5);
        ck_assert_uint_eq(i < 5 ? c[i].feature_a : c[i].feature_b, i < 5 ? i : i - 5);
        double d = 0;
        for (int s = 0; s < 15; s++)
            d += fabs(a->vectors[c[i].feature_a * 15 + s] -
                      b->vectors[c[i].feature_b * 15 + s]);
        ck_assert_double_eq(d, c[i].distance);
        sum += d;
    }
    ck_assert_double_eq_tol(sum, ab, 1e-9 * ab);
    ck_assert_int_eq(phks_match(a, b, c, 13, &count, &score),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    ck_assert_uint_eq(count, 14);
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("codec");
    TCase *c = tcase_create("codec");
    tcase_add_test(c, round_trip_is_exact);
    tcase_add_test(c, layout_is_little_endian);
    tcase_add_test(c, format_1_still_reads);
    tcase_add_test(c, format_3_only_with_quadrature);
    tcase_add_test(c, small_buffer_reports_the_size);
    tcase_add_test(c, every_damage_is_refused);
    tcase_add_test(c, short_blob_is_truncated_whatever_its_format);
    tcase_add_test(c, valid_checksum_impossible_numbers);
    tcase_add_test(c, incompatible_options_refuse_to_score);
    tcase_add_test(c, score_is_the_symmetric_nearest_sum);
    tcase_add_test(c, format_5_round_trip_keeps_the_spin_images);
    tcase_add_test(c, heat_keeps_format_4_bytes);
    tcase_add_test(c, nearest_blobs_leave_the_descriptor_out);
    tcase_add_test(c, format_5_damage_is_refused);
    tcase_add_test(c, local_descriptors_compare_only_when_verified);
    tcase_add_test(c, format_6_round_trip_keeps_the_shape_distribution);
    tcase_add_test(c, format_6_holds_heat_too);
    tcase_add_test(c, none_keeps_older_formats);
    tcase_add_test(c, nearest_blobs_leave_the_global_descriptor_out);
    tcase_add_test(c, format_6_damage_is_refused);
    tcase_add_test(c, global_descriptors_compare_only_when_verified);
    suite_add_tcase(s, c);
    return run_suite(s);
}
