/*
 * example_engine FILE: an engine's frame loop over one SWPM file of any encoding, written from README
 * "Drawing from C" and swpm_reader.h's comments only (Forsyth's VIPM methods: sliding window, vanilla, skip
 * strips, mixed). No GPU: "upload" copies into a software index buffer and "draw" walks it as the GPU would
 * (triangle list, or strip with primitive restart), counting the triangles that are not degenerate and
 * checking every index against the LOD's vertex count. The file's bytes, the scratch and the instance
 * buffers sit at odd addresses, as an engine's memory may hand them over. Compiles as C99 and as C++.
 *
 * A camera flies away (a triangle budget falling from LOD 0's count to 0), then back (a screen-space error
 * bound, converted to mesh units as README says, falling to 0). Prints one JSON object: "encoding",
 * "frames": [kind (0 budget, 1 screen-space error), the budget or max pixels (distance 10, fov_y 1, 1080
 * pixels high), LOD, triangles drawn, vertices used,
 * index bytes uploaded that frame (an instance's dirty range, swpm_*_take_dirty; init's whole buffer in the
 * first frame)], and "bad": frames that drew an index past the used vertices or a strip
 * that restarts where it may not. Exit 0, 1 when the file is rejected (code and offset printed), 2 on I/O.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SWPM_READER_IMPLEMENTATION
#include "swpm_reader.h"

static void *odd_alloc(size_t n) {
    uint8_t *p = (uint8_t *)malloc(n + 1);
    return p ? p + 1 : NULL;
}
static void odd_free(void *p) {
    if (p) free((uint8_t *)p - 1);
}

/* The "GPU": index i of a buffer of width w (little-endian, as uploaded). */
static uint32_t gpu_index(const uint8_t *ib, uint32_t w, uint64_t i) {
    const uint8_t *q = ib + (uint64_t)w * i;
    uint32_t v = (uint32_t)q[0] | (uint32_t)q[1] << 8;
    return w == 2 ? v : v | (uint32_t)q[2] << 16 | (uint32_t)q[3] << 24;
}

/* Draw n indices as a triangle list or strip; returns the triangles drawn that are not degenerate. */
static uint64_t gpu_draw(int strip, int restart_on, uint64_t restart, const uint8_t *ib, uint32_t w, uint64_t n,
                         uint32_t used, int *bad) {
    uint64_t i, tris = 0, run = 0;
    uint32_t a = 0, b = 0;
    for (i = 0; i < n; i++) {
        uint32_t c = gpu_index(ib, w, i);
        if (strip && restart_on && c == restart) {
            run = 0;
            continue;
        }
        if (c >= used) *bad = 1;
        if (strip ? run >= 2 : i % 3 == 2) {
            if (!strip) a = gpu_index(ib, w, i - 2), b = gpu_index(ib, w, i - 1);
            tris += a != b && b != c && a != c;
        }
        a = b, b = c, run++;
    }
    return tris;
}

/* Upload slots [first, end) of the instance's buffer into the "GPU"'s copy (glBufferSubData's part). */
static void upload(uint8_t *gpu_ib, const uint8_t *ib, uint32_t w, uint64_t first, uint64_t end, uint64_t *bytes) {
    memcpy(gpu_ib + first * w, ib + first * w, (size_t)((end - first) * w));
    *bytes = (end - first) * w;
}

/* Screen-space error: the bound in mesh units for max_pixels at distance (README, swpm_lod_for_error). */
static uint64_t lod_for_screen(const swpm_file *f, double max_pixels, double distance, double fov_y, int height) {
    if (distance <= 0.0) return 0;
    return swpm_lod_for_error(f, max_pixels / ((double)height / (2.0 * distance * tan(0.5 * fov_y))));
}

int main(int argc, char **argv) {
    FILE *fp;
    long size;
    uint8_t *bytes, *ib, *gpu_ib;
    void *scratch;
    swpm_file f;
    swpm_result r;
    swpm_vanilla_instance vi;
    swpm_level_instance li;
    uint64_t L, count, restart = 0, step, frames, ib_bytes;
    uint32_t w;
    int enc, strip, restart_on, bad = 0;
    const uint8_t *pool;
    static const char *const names[5] = {"", "vanilla", "sliding-window", "skip-strip", "mixed"};

    if (argc != 2 || !(fp = fopen(argv[1], "rb"))) return 2;
    if (fseek(fp, 0, SEEK_END) != 0 || (size = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET) != 0) return 2;
    bytes = (uint8_t *)odd_alloc((size_t)size);
    if (!bytes || fread(bytes, 1, (size_t)size, fp) != (size_t)size) return 2;
    fclose(fp);
    /* open: the file's length always suffices as scratch (README), which is free again after the open */
    scratch = odd_alloc((size_t)size);
    r = swpm_open_ex(bytes, (size_t)size, &f, scratch, (size_t)size);
    odd_free(scratch);
    if (r.code) {
        printf("{\"code\":\"%s\",\"offset\":%llu}\n", r.code, (unsigned long long)r.offset);
        return 1;
    }
    enc = swpm_encoding(&f);
    L = swpm_lod_count(&f);
    pool = swpm_index_pool(&f, &count, &w); /* sliding-window, mixed: uploaded once, shared */
    strip = swpm_primitive_strip(&f);
    restart_on = swpm_restart_index(&f, &restart);
    /* one instance's index buffer: vanilla a copy of INDX, skip-strip / mixed a level list */
    ib_bytes = enc == 1 ? count * w : swpm_level_instance_bytes(&f);
    ib = (uint8_t *)odd_alloc((size_t)ib_bytes);
    gpu_ib = (uint8_t *)odd_alloc((size_t)ib_bytes); /* the "GPU"'s copy: written only by uploads */
    if (!ib || !gpu_ib || (enc == 1 && !swpm_vanilla_instance_init(&f, &vi, ib, ib_bytes)) ||
        (enc == 3 && !swpm_skip_instance_init(&f, &li, ib, ib_bytes)) ||
        (enc == 4 && !swpm_mixed_instance_init(&f, &li, ib, ib_bytes)))
        return 2;
    printf("{\"encoding\":\"%s\",\"frames\":[", names[enc]);
    frames = L < 64 ? 2 * L : 128;
    for (step = 0; step < frames; step++) {
        const uint64_t half = frames / 2, t = half - 1 - step % half; /* t falls to 0 */
        const int by_error = step >= half;
        uint64_t budget = swpm_lod_triangle_count(&f, 0) * t / (half > 1 ? half - 1 : 1);
        double bound = (double)swpm_lod_error(&f, L - 1) * (double)t / (double)half;
        double pixels = 0.0, distance = 10.0, fov_y = 1.0;
        uint64_t k, n, drawn = 0, first, end, static_first, static_count, uploaded = 0;
        uint32_t used;
        if (by_error) {
            /* (pixels so that the bound in mesh units is `bound`, through the README's formula) */
            pixels = bound * 1080.0 / (2.0 * distance * tan(0.5 * fov_y));
            k = lod_for_screen(&f, pixels, distance, fov_y, 1080);
        } else {
            k = swpm_lod_for_triangles(&f, budget);
        }
        if (enc == 2) { /* sliding window: a range of the shared pool */
            swpm_window(&f, k, &first, &n, &used);
            drawn = gpu_draw(strip, restart_on, restart, pool + first * w, w, n, used, &bad);
        } else if (enc == 1) { /* vanilla: the instance's list, its first n indices */
            n = swpm_vanilla_set_lod(&f, &vi, k, &used);
            if (swpm_vanilla_take_dirty(&vi, &first, &end)) /* the slots written since (init: all) */
                upload(gpu_ib, ib, w, first, end, &uploaded);
            drawn = gpu_draw(0, 0, 0, gpu_ib, w, n, used, &bad);
        } else if (enc == 3) { /* skip-strip: the instance's whole level list */
            n = swpm_skip_set_lod(&f, &li, k, &used);
            if (swpm_level_take_dirty(&li, &first, &end))
                upload(gpu_ib, ib, w, first, end, &uploaded);
            drawn = gpu_draw(strip, restart_on, restart, gpu_ib, w, n, used, &bad);
        } else { /* mixed: the instance's live dynamic prefix, then the shared static range */
            n = swpm_mixed_set_lod(&f, &li, k, &static_first, &static_count, &used);
            if (swpm_level_take_dirty(&li, &first, &end))
                upload(gpu_ib, ib, w, first, end, &uploaded);
            drawn = gpu_draw(0, 0, 0, gpu_ib, w, n, used, &bad) +
                    gpu_draw(0, 0, 0, pool + static_first * w, w, static_count, used, &bad);
        }
        printf("%s[%d,%.17g,%llu,%llu,%u,%llu]", step ? "," : "", by_error,
               by_error ? pixels : (double)budget, (unsigned long long)k, (unsigned long long)drawn, used,
               (unsigned long long)uploaded);
    }
    printf("],\"bad\":%d}\n", bad);
    odd_free(gpu_ib);
    odd_free(ib);
    odd_free(bytes);
    return 0;
}
