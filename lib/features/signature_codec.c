/*
 * signature_codec.c - signatures as portable byte blobs (docs/formats.md).
 *
 * Layout, all integers and doubles little-endian (doubles as IEEE-754
 * bit patterns), whatever the host:
 *   magic "PHKS"  u16 format (1)  u16 flags (0)
 *   f64 tau  f64 cutoff  u32 eigen_count  u32 feature_count
 *   f64 feature_scale  u32 operator  u32 box  u32 scale_count
 *   (format 2 on:) f64 boundary_margin  u32 hks_scaling
 *   (format 3 on:) u32 quadrature
 *   (format 4 on:) u32 matching
 *   (format 5 on:) u32 local_descriptor
 *   (format 6 on:) u32 global_descriptor
 *   f64 scales[scale_count]
 *   u32 count, then per feature:
 *     u32 vertex  f64 x y z  f64 persistence  f64 vector[scale_count]
 *   (format 4 on, matching VERIFIED:) u32 samples, then per sample:
 *     u32 vertex  f32 x y z  f32 vector[scale_count]
 *   then, with p = count + samples points, f32 boundary[p] and
 *   f32 geodesic[p (p - 1) / 2], the pairs i < j in the order j = 1..,
 *   i = 0..j-1
 *   (format 5 on, matching VERIFIED, local_descriptor SPIN:)
 *   f64 unit_scale (positions times it lie in the unit box, so the
 *   points' straight-line distances there are known), then
 *   u8 spin[p * PHKS__SPIN_BYTES], each point's images as sig->spin holds
 *   them, features first
 *   (format 6 on, matching VERIFIED, global_descriptor D2:)
 *   u8 shape[PHKS__SHAPE_BINS], the shape distribution as sig->shape
 *   holds it
 *   u32 CRC-32 of every byte before it
 * A reader refuses a format number above its own rather than guess
 * (unless the blob is too short for any format: SMALLEST_BLOB), and
 * reads every older one: format 1 blobs predate the two format-2 fields and
 * were made with them zero, format 2 ones predate the quadrature (0, the
 * vertices'), format 3 ones the matching (0, the nearest), format 4 ones
 * the local descriptor (0, the heat vectors), format 5 ones the global
 * descriptor (0, none). The writer uses the oldest format that holds the
 * options: format 2 while quadrature and matching are 0, so that a
 * signature made without them has the bytes it had before (and older
 * readers still read it). Format 5 only for VERIFIED signatures with a
 * local descriptor other than HEAT, format 6 only for VERIFIED ones with
 * a global descriptor other than NONE (it then holds the local
 * descriptor too, whatever it is): NEAREST ignores both descriptors, so
 * its blobs leave them out, keep their old bytes and decode with HEAT and
 * NONE, whatever values the signature was made with (they score alike;
 * phks__options_difference does not compare them there).
 */
#include "features/features.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define FORMAT 6
#define HEADER_SIZE_1 (4 + 2 + 2 + 8 + 8 + 4 + 4 + 8 + 4 + 4 + 4)
#define FORMAT_2_FIELDS (8 + 4)
#define FORMAT_3_FIELDS 4
#define FORMAT_4_FIELDS 4
#define FORMAT_5_FIELDS 4
#define FORMAT_6_FIELDS 4
#define FEATURE_FIXED (4 + 3 * 8 + 8)
/* Every format, this library's and later ones, starts with format 1's
 * header (later formats add their fields after it) and ends with the
 * checksum: a blob shorter than both is cut short whatever number its
 * format field holds, and is not taken for a newer format's. */
#define SMALLEST_BLOB (HEADER_SIZE_1 + 4)

static size_t header_size(unsigned format)
{
    return HEADER_SIZE_1 + (format >= 2 ? FORMAT_2_FIELDS : 0) +
           (format >= 3 ? FORMAT_3_FIELDS : 0) +
           (format >= 4 ? FORMAT_4_FIELDS : 0) +
           (format >= 5 ? FORMAT_5_FIELDS : 0) +
           (format >= 6 ? FORMAT_6_FIELDS : 0);
}

/* Whether a signature made with o carries spin images: they sit beside
 * the layout, which only VERIFIED signatures have. */
static bool has_spin(const phks_options *o)
{
    return o->matching == PHKS_MATCHING_VERIFIED &&
           o->local_descriptor == PHKS_LOCAL_DESCRIPTOR_SPIN;
}

/* Whether a signature made with o carries a shape distribution: it sits
 * beside the layout too, and only the verified score reads it. */
static bool carries_shape(const phks_options *o)
{
    return o->matching == PHKS_MATCHING_VERIFIED &&
           o->global_descriptor == PHKS_GLOBAL_DESCRIPTOR_D2;
}

/* samples is SIZE_MAX for a signature without a layout (NEAREST), and o
 * is then not read; with a layout, o says which descriptors follow it. */
static size_t blob_size(unsigned format, size_t scales, size_t count,
                        size_t samples, const phks_options *o)
{
    size_t size = header_size(format) + 8 * scales + 4 +
                  count * (FEATURE_FIXED + 8 * scales) + 4;
    if (samples == SIZE_MAX)
        return size;
    size_t points = count + samples;
    return size + 4 + samples * (4 + 12 + 4 * scales) + 4 * points +
           4 * phks__pair_count(points) +
           (has_spin(o) ? 8 + points * PHKS__SPIN_BYTES : 0) +
           (carries_shape(o) ? PHKS__SHAPE_BINS : 0);
}

static size_t layout_samples(const phks_signature *sig)
{
    return sig->options.matching == PHKS_MATCHING_VERIFIED ? sig->samples
                                                           : SIZE_MAX;
}

static unsigned char *put_u16(unsigned char *p, uint16_t x)
{
    p[0] = (unsigned char)x;
    p[1] = (unsigned char)(x >> 8);
    return p + 2;
}

static unsigned char *put_u32(unsigned char *p, uint32_t x)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(x >> (8 * i));
    return p + 4;
}

static unsigned char *put_f32(unsigned char *p, float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return put_u32(p, u);
}

static unsigned char *put_f64(unsigned char *p, double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(u >> (8 * i));
    return p + 8;
}

static uint16_t get_u16(const unsigned char **p)
{
    uint16_t x = (uint16_t)((*p)[0] | (*p)[1] << 8);
    *p += 2;
    return x;
}

static uint32_t get_u32(const unsigned char **p)
{
    uint32_t x = 0;
    for (int i = 0; i < 4; i++)
        x |= (uint32_t)(*p)[i] << (8 * i);
    *p += 4;
    return x;
}

static float get_f32(const unsigned char **p)
{
    uint32_t u = get_u32(p);
    float x;
    memcpy(&x, &u, sizeof x);
    return x;
}

static double get_f64(const unsigned char **p)
{
    uint64_t u = 0;
    for (int i = 0; i < 8; i++)
        u |= (uint64_t)(*p)[i] << (8 * i);
    *p += 8;
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* The oldest format that holds sig's options (see the top comment). */
static unsigned format_of(const phks_signature *sig)
{
    const phks_options *o = &sig->options;
    if (o->matching == PHKS_MATCHING_NEAREST)
        return o->quadrature != PHKS_QUADRATURE_VERTICES ? 3 : 2;
    if (o->global_descriptor != PHKS_GLOBAL_DESCRIPTOR_NONE)
        return 6;
    return o->local_descriptor != PHKS_LOCAL_DESCRIPTOR_HEAT ? 5 : 4;
}

static unsigned char *put_layout(unsigned char *p, const phks_signature *sig)
{
    size_t points = phks__signature_points(sig);
    p = put_u32(p, (uint32_t)sig->samples);
    for (size_t i = sig->count; i < points; i++) {
        p = put_u32(p, sig->vertex[i]);
        for (int d = 0; d < 3; d++)
            p = put_f32(p, (float)sig->position[3 * i + d]);
        for (size_t s = 0; s < sig->length; s++)
            p = put_f32(p, (float)sig->vectors[i * sig->length + s]);
    }
    for (size_t i = 0; i < points; i++)
        p = put_f32(p, sig->boundary[i]);
    for (size_t k = 0; k < phks__pair_count(points); k++)
        p = put_f32(p, sig->geodesic[k]);
    if (has_spin(&sig->options)) {
        p = put_f64(p, sig->unit_scale);
        /* Bytes already: no byte order to fix. */
        memcpy(p, sig->spin, points * PHKS__SPIN_BYTES);
        p += points * PHKS__SPIN_BYTES;
    }
    if (carries_shape(&sig->options)) {
        memcpy(p, sig->shape, PHKS__SHAPE_BINS);
        p += PHKS__SHAPE_BINS;
    }
    return p;
}

static void get_layout(const unsigned char *p, phks_signature *sig)
{
    size_t points = phks__signature_points(sig);
    for (size_t i = sig->count; i < points; i++) {
        sig->vertex[i] = get_u32(&p);
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = get_f32(&p);
        sig->persistence[i] = 0;
        for (size_t s = 0; s < sig->length; s++)
            sig->vectors[i * sig->length + s] = get_f32(&p);
    }
    for (size_t i = 0; i < points; i++)
        sig->boundary[i] = get_f32(&p);
    for (size_t k = 0; k < phks__pair_count(points); k++)
        sig->geodesic[k] = get_f32(&p);
    if (has_spin(&sig->options)) {
        sig->unit_scale = get_f64(&p);
        memcpy(sig->spin, p, points * PHKS__SPIN_BYTES);
        p += points * PHKS__SPIN_BYTES;
    }
    sig->has_shape = carries_shape(&sig->options);
    if (sig->has_shape)
        memcpy(sig->shape, p, PHKS__SHAPE_BINS);
}

size_t phks_signature_encoded_size(const phks_signature *sig)
{
    return sig ? blob_size(format_of(sig), sig->length, sig->count,
                           layout_samples(sig), &sig->options)
               : 0;
}

phks_status phks_signature_encode(const phks_signature *sig, void *buffer,
                                  size_t capacity, size_t *size)
{
    if (!sig || !size || (!buffer && capacity))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_encode: NULL argument");
    if (layout_samples(sig) != SIZE_MAX && (!sig->geodesic || !sig->boundary))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_encode: a verified-matching "
                         "signature without its distances");
    if (has_spin(&sig->options) && !sig->spin)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_encode: a spin-image signature "
                         "without its images");
    if (carries_shape(&sig->options) && !sig->has_shape)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_encode: a D2 signature without its "
                         "shape distribution");
    const unsigned format = format_of(sig);
    size_t need = blob_size(format, sig->length, sig->count,
                            layout_samples(sig), &sig->options);
    *size = need;
    if (capacity < need)
        return phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                         "phks_signature_encode: %zu bytes needed, room for %zu",
                         need, capacity);
    const phks_options *o = &sig->options;
    unsigned char *start = buffer, *p = start;
    memcpy(p, "PHKS", 4);
    p = put_u16(p + 4, (uint16_t)format);
    p = put_u16(p, 0);
    p = put_f64(p, o->tau);
    p = put_f64(p, o->cutoff);
    p = put_u32(p, o->eigen_count);
    p = put_u32(p, o->feature_count);
    p = put_f64(p, o->feature_scale);
    p = put_u32(p, (uint32_t)o->operator_kind);
    p = put_u32(p, (uint32_t)o->box);
    p = put_u32(p, o->scale_count);
    p = put_f64(p, o->boundary_margin);
    p = put_u32(p, (uint32_t)o->hks_scaling);
    if (format >= 3)
        p = put_u32(p, (uint32_t)o->quadrature);
    if (format >= 4)
        p = put_u32(p, (uint32_t)o->matching);
    if (format >= 5)
        p = put_u32(p, (uint32_t)o->local_descriptor);
    if (format >= 6)
        p = put_u32(p, (uint32_t)o->global_descriptor);
    for (uint32_t s = 0; s < o->scale_count; s++)
        p = put_f64(p, o->scales[s]);
    p = put_u32(p, (uint32_t)sig->count);
    for (size_t i = 0; i < sig->count; i++) {
        p = put_u32(p, sig->vertex[i]);
        for (int d = 0; d < 3; d++)
            p = put_f64(p, sig->position[3 * i + d]);
        p = put_f64(p, sig->persistence[i]);
        for (size_t s = 0; s < sig->length; s++)
            p = put_f64(p, sig->vectors[i * sig->length + s]);
    }
    if (layout_samples(sig) != SIZE_MAX)
        p = put_layout(p, sig);
    put_u32(p, phks__crc32(start, (size_t)(p - start)));
    return PHKS_OK;
}

/* Numbers that passed the checksum can still be impossible, for a blob
 * made by something other than this library: check them like options. */
static phks_status check_numbers(const phks_signature *sig)
{
    phks_options check;
    if (phks__options_resolve(&sig->options, &check) != PHKS_OK) {
        /* A copy: the message buffer cannot be printed into itself. */
        char why[256];
        snprintf(why, sizeof why, "%s", phks_last_error_message());
        return phks__fail(PHKS_ERROR_CORRUPT, "signature blob: bad options (%s)",
                         why);
    }
    for (size_t i = 0; i < phks__signature_points(sig); i++) {
        bool ok = !isnan(sig->persistence[i]) && sig->persistence[i] >= 0;
        for (int d = 0; d < 3; d++)
            ok = ok && isfinite(sig->position[3 * i + d]);
        for (size_t s = 0; s < sig->length; s++)
            ok = ok && isfinite(sig->vectors[i * sig->length + s]);
        /* Pieces that stay apart are INFINITY apart; never negative. */
        for (size_t j = 0; ok && sig->geodesic && j < i; j++)
            ok = sig->geodesic[phks__pair_index(j, i)] >= 0;
        ok = ok && (!sig->boundary || sig->boundary[i] >= 0);
        /* 0: unknown (a database's options blob has no box). */
        ok = ok && (!sig->spin || (isfinite(sig->unit_scale) &&
                                   sig->unit_scale >= 0));
        if (!ok)
            return phks__fail(PHKS_ERROR_CORRUPT,
                             "signature blob: feature %zu holds an impossible "
                             "number", i);
    }
    return PHKS_OK;
}

static phks_status too_short(size_t size)
{
    return phks__fail(PHKS_ERROR_TRUNCATED,
                      "signature blob: %zu bytes, shorter than any format's "
                      "header and checksum (%d bytes)",
                      size, SMALLEST_BLOB);
}

phks_status phks_signature_decode(const void *buffer, size_t size,
                                  phks_signature **out)
{
    if (out)
        *out = NULL;
    if (!buffer || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_decode: NULL argument");
    const unsigned char *start = buffer, *p = start;
    if (size < 8)
        return too_short(size);
    if (memcmp(p, "PHKS", 4) != 0)
        return phks__fail(PHKS_ERROR_CORRUPT, "signature blob: bad magic bytes");
    if (size < SMALLEST_BLOB)
        return too_short(size);
    p += 4;
    uint16_t format = get_u16(&p), flags = get_u16(&p);
    if (format > FORMAT)
        return phks__fail(PHKS_ERROR_UNSUPPORTED_VERSION,
                         "signature blob: format %u is newer than this "
                         "library's %d",
                         format, FORMAT);
    if (format == 0 || flags != 0)
        return phks__fail(PHKS_ERROR_CORRUPT,
                         "signature blob: format %u flags %u", format, flags);
    if (size < header_size(format) + 4)
        return phks__fail(PHKS_ERROR_TRUNCATED, "signature blob: %zu bytes", size);

    phks_options o;
    phks_options_init(&o);
    o.tau = get_f64(&p);
    o.cutoff = get_f64(&p);
    o.eigen_count = get_u32(&p);
    o.feature_count = get_u32(&p);
    o.feature_scale = get_f64(&p);
    o.operator_kind = (int32_t)get_u32(&p);
    o.box = (int32_t)get_u32(&p);
    o.scale_count = get_u32(&p);
    o.boundary_margin = 0;
    o.hks_scaling = PHKS_HKS_SCALING_NONE;
    if (format >= 2) {
        o.boundary_margin = get_f64(&p);
        o.hks_scaling = (int32_t)get_u32(&p);
    }
    o.quadrature = PHKS_QUADRATURE_VERTICES;
    if (format >= 3)
        o.quadrature = (int32_t)get_u32(&p);
    o.matching = PHKS_MATCHING_NEAREST;
    if (format >= 4)
        o.matching = (int32_t)get_u32(&p);
    o.local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    if (format >= 5)
        o.local_descriptor = (int32_t)get_u32(&p);
    o.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_NONE;
    if (format >= 6)
        o.global_descriptor = (int32_t)get_u32(&p);
    if (o.scale_count < 1 || o.scale_count > PHKS_MAX_SCALES)
        return phks__fail(PHKS_ERROR_CORRUPT, "signature blob: %u scales",
                         o.scale_count);
    if (size < header_size(format) + 8 * (size_t)o.scale_count + 8)
        return phks__fail(PHKS_ERROR_TRUNCATED, "signature blob: %zu bytes", size);
    for (uint32_t s = 0; s < o.scale_count; s++)
        o.scales[s] = get_f64(&p);
    uint32_t count = get_u32(&p);
    /* The samples' count sits after the features. */
    size_t samples = SIZE_MAX;
    size_t features_end =
        blob_size(format, o.scale_count, count, SIZE_MAX, &o) - 4;
    if (o.matching == PHKS_MATCHING_VERIFIED) {
        if (size < features_end + 4)
            return phks__fail(PHKS_ERROR_TRUNCATED,
                             "signature blob: %zu bytes, %u features need more",
                             size, count);
        const unsigned char *at = start + features_end;
        samples = get_u32(&at);
        if (samples > PHKS__SAMPLES)
            return phks__fail(PHKS_ERROR_CORRUPT,
                             "signature blob: %zu samples", samples);
    }
    size_t need = blob_size(format, o.scale_count, count, samples, &o);
    if (size < need)
        return phks__fail(PHKS_ERROR_TRUNCATED,
                         "signature blob: %zu bytes, %u features need %zu",
                         size, count, need);
    if (size > need)
        return phks__fail(PHKS_ERROR_CORRUPT,
                         "signature blob: %zu bytes, %u features need %zu",
                         size, count, need);
    const unsigned char *crc_at = start + need - 4;
    uint32_t stored = get_u32(&crc_at);
    if (stored != phks__crc32(start, need - 4))
        return phks__fail(PHKS_ERROR_CORRUPT, "signature blob: checksum mismatch");
    if (count == 0)
        return phks__fail(PHKS_ERROR_CORRUPT, "signature blob: no features");

    phks_signature *sig;
    phks_status st = phks__signature_alloc(
        count, samples == SIZE_MAX ? 0 : samples, o.scale_count, &sig);
    if (st != PHKS_OK)
        return st;
    /* Before the layout: the options say which descriptors it has. */
    sig->options = o;
    if (samples != SIZE_MAX) {
        st = phks__signature_alloc_layout(sig);
        if (st != PHKS_OK) {
            phks_signature_free(sig);
            return st;
        }
    }
    for (size_t i = 0; i < count; i++) {
        sig->vertex[i] = get_u32(&p);
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = get_f64(&p);
        sig->persistence[i] = get_f64(&p);
        for (size_t s = 0; s < o.scale_count; s++)
            sig->vectors[i * o.scale_count + s] = get_f64(&p);
    }
    if (samples != SIZE_MAX)
        get_layout(p + 4, sig);
    st = check_numbers(sig);
    if (st != PHKS_OK) {
        phks_signature_free(sig);
        return st;
    }
    *out = sig;
    return PHKS_OK;
}
