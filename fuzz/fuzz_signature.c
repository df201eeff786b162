/*
 * fuzz_signature.c - phks_signature_decode on any bytes, and on the same
 * bytes with their last four replaced by the right CRC-32, so that damaged
 * fields get past the checksum and reach the checks behind it.
 *
 * For every blob accepted: the signature is sane; encoding it gives back
 * the blob itself (in the format the encoder picks for its options), a
 * longer one (an older format gains the newer fields) or a shorter one (a
 * newer format holding only older options, or descriptors that NEAREST
 * ignores, loses them); and decode(encode(decode(x))) is decode(x), field
 * by field and bit for bit (the descriptors where they count: with
 * VERIFIED), and scores 0 against it.
 */
#include "fuzz_common.h"

static bool same_bits(const void *a, const void *b, size_t n)
{
    return n == 0 || memcmp(a, b, n) == 0;
}

static void check_sane(const phks_signature *sig)
{
    size_t count = phks_signature_feature_count(sig);
    size_t length = phks_signature_vector_length(sig);
    FUZZ_CHECK(count >= 1);
    FUZZ_CHECK(length >= 1 && length <= PHKS_MAX_SCALES);
    FUZZ_CHECK(length == sig->options.scale_count);
    /* The samples of a verified signature follow the features. */
    size_t points = count + phks_signature_sample_count(sig);
    FUZZ_CHECK(points == count ||
               sig->options.matching == PHKS_MATCHING_VERIFIED);
    /* Spin images exactly with VERIFIED and SPIN. */
    FUZZ_CHECK((sig->spin != NULL) ==
               (sig->options.matching == PHKS_MATCHING_VERIFIED &&
                sig->options.local_descriptor == PHKS_LOCAL_DESCRIPTOR_SPIN));
    /* A shape distribution exactly with VERIFIED and D2. */
    FUZZ_CHECK(sig->has_shape ==
               (sig->options.matching == PHKS_MATCHING_VERIFIED &&
                sig->options.global_descriptor == PHKS_GLOBAL_DESCRIPTOR_D2));
    for (size_t i = 0; i < points; i++) {
        if (sig->boundary)
            FUZZ_CHECK(sig->boundary[i] >= 0);
        for (size_t j = 0; sig->geodesic && j < i; j++)
            FUZZ_CHECK(sig->geodesic[phks__pair_index(j, i)] >= 0);
        double xyz[3];
        FUZZ_CHECK(phks_signature_feature_position(sig, i, xyz) == PHKS_OK);
        for (int d = 0; d < 3; d++)
            FUZZ_CHECK(isfinite(xyz[d]));
        double p = phks_signature_feature_persistence(sig, i);
        FUZZ_CHECK(p >= 0); /* not NaN */
        const double *v = phks_signature_feature_vector(sig, i);
        FUZZ_CHECK(v != NULL);
        for (size_t s = 0; s < length; s++)
            FUZZ_CHECK(isfinite(v[s]));
    }
    FUZZ_CHECK(phks_signature_feature_vector(sig, points) == NULL);
}

static void check_same(const phks_signature *a, const phks_signature *b)
{
    FUZZ_CHECK(a->count == b->count && a->length == b->length &&
               a->samples == b->samples);
    size_t points = phks__signature_points(a);
    const phks_options *x = &a->options, *y = &b->options;
    FUZZ_CHECK(same_bits(&x->tau, &y->tau, sizeof x->tau));
    FUZZ_CHECK(same_bits(&x->cutoff, &y->cutoff, sizeof x->cutoff));
    FUZZ_CHECK(x->eigen_count == y->eigen_count);
    FUZZ_CHECK(x->feature_count == y->feature_count);
    FUZZ_CHECK(same_bits(&x->feature_scale, &y->feature_scale,
                         sizeof x->feature_scale));
    FUZZ_CHECK(x->operator_kind == y->operator_kind && x->box == y->box);
    FUZZ_CHECK(x->scale_count == y->scale_count);
    FUZZ_CHECK(same_bits(x->scales, y->scales,
                         x->scale_count * sizeof *x->scales));
    FUZZ_CHECK(same_bits(&x->boundary_margin, &y->boundary_margin,
                         sizeof x->boundary_margin));
    FUZZ_CHECK(x->hks_scaling == y->hks_scaling);
    FUZZ_CHECK(phks__options_comparable(x, y));
    FUZZ_CHECK(same_bits(a->vertex, b->vertex, points * sizeof *a->vertex));
    FUZZ_CHECK(same_bits(a->position, b->position,
                         3 * points * sizeof *a->position));
    FUZZ_CHECK(same_bits(a->persistence, b->persistence,
                         points * sizeof *a->persistence));
    FUZZ_CHECK(same_bits(a->vectors, b->vectors,
                         points * a->length * sizeof *a->vectors));
    FUZZ_CHECK((a->geodesic == NULL) == (b->geodesic == NULL));
    if (a->geodesic) {
        FUZZ_CHECK(same_bits(a->geodesic, b->geodesic,
                             phks__pair_count(points) * sizeof *a->geodesic));
        FUZZ_CHECK(same_bits(a->boundary, b->boundary,
                             points * sizeof *a->boundary));
    }
    FUZZ_CHECK((a->spin == NULL) == (b->spin == NULL));
    if (a->spin) {
        FUZZ_CHECK(x->local_descriptor == y->local_descriptor);
        FUZZ_CHECK(same_bits(a->spin, b->spin, points * PHKS__SPIN_BYTES));
    }
    FUZZ_CHECK(a->has_shape == b->has_shape);
    if (a->has_shape) {
        FUZZ_CHECK(x->global_descriptor == y->global_descriptor);
        FUZZ_CHECK(same_bits(a->shape, b->shape, PHKS__SHAPE_BINS));
    }
    double score = -1;
    FUZZ_CHECK(phks_score(a, b, &score) == PHKS_OK && score == 0);
}

static unsigned char *encode(const phks_signature *sig, size_t *size)
{
    size_t need = phks_signature_encoded_size(sig);
    FUZZ_CHECK(need > 0);
    unsigned char *blob = malloc(need);
    FUZZ_CHECK(blob != NULL);
    *size = 0;
    FUZZ_CHECK(phks_signature_encode(sig, blob, need, size) == PHKS_OK);
    FUZZ_CHECK(*size == need);
    if (need > 1) { /* one byte short is refused, with the size needed */
        size_t told = 0;
        FUZZ_CHECK(phks_signature_encode(sig, blob, need - 1, &told) ==
                   PHKS_ERROR_BUFFER_TOO_SMALL);
        FUZZ_CHECK(told == need);
        FUZZ_CHECK(phks_signature_encode(sig, blob, need, size) == PHKS_OK);
    }
    return blob;
}

static void decode_and_round_trip(const uint8_t *data, size_t size)
{
    char *copy = fuzz_copy(data, size);
    phks_signature *sig = (phks_signature *)&sig; /* must be reset */
    fuzz_clear_message();
    phks_status st = phks_signature_decode(copy, size, &sig);
    if (st != PHKS_OK) {
        fuzz_check_failure(st);
        FUZZ_CHECK(sig == NULL);
        free(copy);
        return;
    }
    FUZZ_CHECK(sig != NULL);
    check_sane(sig);

    size_t n1;
    unsigned char *blob1 = encode(sig, &n1);
    /* The format number is bytes 4-5; encode writes the current one. */
    unsigned format = (unsigned)data[4] | (unsigned)data[5] << 8;
    unsigned current = (unsigned)blob1[4] | (unsigned)blob1[5] << 8;
    /* A newer format holding only older options is read, and written
     * back in the oldest format that holds them. */
    FUZZ_CHECK(format >= 1 && format <= 6 && current <= 6);
    if (format == current)
        FUZZ_CHECK(n1 == size && memcmp(blob1, data, size) == 0);
    else if (format < current) /* an older blob gains the newer fields */
        FUZZ_CHECK(n1 > size);
    else /* a newer one holding only older options loses them */
        FUZZ_CHECK(n1 < size);

    phks_signature *again = NULL;
    FUZZ_CHECK(phks_signature_decode(blob1, n1, &again) == PHKS_OK);
    check_same(sig, again);
    size_t n2;
    unsigned char *blob2 = encode(again, &n2);
    FUZZ_CHECK(n2 == n1 && memcmp(blob1, blob2, n1) == 0);

    free(blob2);
    free(blob1);
    phks_signature_free(again);
    phks_signature_free(sig);
    free(copy);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    decode_and_round_trip(data, size);
    if (size < 4)
        return 0;
    unsigned char *fixed = malloc(size);
    FUZZ_CHECK(fixed != NULL);
    memcpy(fixed, data, size);
    uint32_t crc = phks__crc32(fixed, size - 4);
    for (int i = 0; i < 4; i++)
        fixed[size - 4 + i] = (unsigned char)(crc >> (8 * i));
    if (memcmp(fixed, data, size) != 0)
        decode_and_round_trip(fixed, size);
    free(fixed);
    return 0;
}
