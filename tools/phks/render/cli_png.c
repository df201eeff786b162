/*
 * cli_png.c - PNG files for `phks` pictures through libspng, an optional
 * dependency of the tool (PHKS_CLI_SPNG is defined when meson found it).
 * The encoding is 8-bit RGB with no time or text chunks, so the same image
 * gives the same bytes.
 */
#include "render/cli_pictures.h"
#include "common/cli_common.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#ifdef PHKS_CLI_SPNG
#include <spng.h>

int cli_png_supported(void)
{
    return 1;
}

int cli_png_write(const char *path, const cli_image *im)
{
    spng_ctx *ctx = spng_ctx_new(SPNG_CTX_ENCODER);
    if (!ctx)
        return cli_error(path, "out of memory");
    struct spng_ihdr ihdr = {0};
    ihdr.width = (uint32_t)im->width;
    ihdr.height = (uint32_t)im->height;
    ihdr.bit_depth = 8;
    ihdr.color_type = SPNG_COLOR_TYPE_TRUECOLOR;
    size_t size = (size_t)im->width * (size_t)im->height * 3, len = 0;
    int err = spng_set_option(ctx, SPNG_ENCODE_TO_BUFFER, 1);
    if (!err)
        err = spng_set_ihdr(ctx, &ihdr);
    if (!err)
        err = spng_encode_image(ctx, im->rgb, size, SPNG_FMT_PNG,
                                SPNG_ENCODE_FINALIZE);
    void *png = err ? NULL : spng_get_png_buffer(ctx, &len, &err);
    spng_ctx_free(ctx);
    if (!png)
        return cli_error(path, spng_strerror(err));
    int rc = cli_write_file_atomic(path, png, len);
    free(png);
    return rc == 0 ? 0 : cli_error(path, strerror(errno));
}

#else

int cli_png_supported(void)
{
    return 0;
}

int cli_png_write(const char *path, const cli_image *im)
{
    (void)im;
    return cli_error(path, "built without PNG support (libspng)");
}

#endif
