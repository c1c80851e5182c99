/*
 * swpm_dump FILE: open an SWPM file (any encoding) with swpm_reader.h (swpm_open_ex, with a scratch
 * of the file's length, the bound the header documents) and print one JSON object.
 * Rejected: {"ok": false, "code": ..., "offset": N or null}, exit 1. Accepted: {"ok": true, the header
 * fields, "arrays": every array of the encoding's summary (spec/format.md 7) as the lowercase hex of its
 * elements in C order in their stored type, little-endian, "lod_for_triangles": [target, LOD] pairs, and
 * sliding-window: "windows": swpm_window of every LOD; vanilla: "instance": a swpm_vanilla_instance moved by
 * swpm_vanilla_set_lod to LODs 0, 1, ..., L-1 and back to 0, each step [lod, index_count, vertex_count, the
 * CRC-32 of the buffer's first index_count indices as stored, the dirty range taken (first, end), and when L <= 8 their hex too] (a CRC, not the
 * hex, on a real file: thousands of LODs times thousands of indices); skip-strip and mixed: "levels",
 * "level_of_lod" and "instance" (see levels() below)}, exit 0. Usage error: exit 2.
 * swpm_dump --check FILE...: one line per file, {"ok": ...} or {"ok": false, "code", "offset"} (a batch
 * for tests: one process for thousands of files); exit 0, 2 when a file cannot be read.
 * swpm_dump --check-scratch N FILE...: --check with a scratch of N bytes (a too-small one adds "need").
 * swpm_dump --prefix N... FILE: open the first N bytes of FILE with swpm_open_prefix (format.md 4.1), in a
 * buffer of exactly N bytes, for each N (N past the file's length: the whole file); one line per N:
 * {"n", "ok", "code", "offset", "need"} and on success "file_size", "lod_count", "finest" (swpm_finest_drawable_lod,
 * L if none), "needed": swpm_lod_needed_bytes of LODs 0, the finest drawable (or L-1), L-1, "points_crc" and
 * "pool_crc" (CRC-32 of the finest drawable LOD's points through swpm_point as f32 LE, null if none; of
 * swpm_index_pool's bytes), "smap": [first_lod, lod_count, range_count, prefix_length, ranges...] per band,
 * "finish": swpm_prefix_finish's result given the whole file (in a buffer of its length), and when it succeeds
 * "whole_crc": [the CRC of every point, of the index pool] read through f after the prefix's buffer is freed.
 * swpm_dump --ranges OFF:LEN,... [--fill HH] FILE: open the held ranges of FILE with swpm_open_ranges (format.md
 * 4.2) in a fresh buffer up to the last held byte, the other bytes set to HH (hex, default 00): one line
 * {"ok", "code", "offset", "need_start", "need"} and on success "lod_count", "finest", "drawable" (the LODs
 * swpm_lod_drawable accepts), "drawn_crc" (one CRC-32 over, for each drawable LOD in order, its points as f32
 * LE then its INDX elements of swpm_lod_index_range as stored), "needed" (swpm_lod_needed_ranges of LODs 0
 * and L-1, flat offset,length pairs), "finish" (swpm_ranges_finish given the whole file) and "whole_crc".
 * The file's bytes, the scratch and the instance buffers are all given at odd addresses (odd_alloc).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SWPM_READER_IMPLEMENTATION
#include "swpm_reader.h"

static void hex(const uint8_t *p, uint64_t n) {
    static const char digits[] = "0123456789abcdef";
    uint64_t i;
    for (i = 0; i < n; i++) {
        putchar(digits[p[i] >> 4]);
        putchar(digits[p[i] & 15]);
    }
}

/* An array of count rows, each of `size` bytes at base + i * step. */
static void array(const char *name, const uint8_t *base, uint64_t count, uint64_t step, uint64_t size,
                  uint64_t rows, uint64_t cols, int first) {
    uint64_t i;
    printf("%s\"%s\":{\"shape\":[%llu", first ? "" : ",", name, (unsigned long long)rows);
    if (cols) printf(",%llu", (unsigned long long)cols);
    printf("],\"hex\":\"");
    for (i = 0; i < count; i++) hex(base + i * step, size);
    printf("\"}");
}

/* The characters of a JSON string, escaped (names are checked UTF-8). */
static void json_chars(const uint8_t *s, uint64_t n) {
    uint64_t i;
    for (i = 0; i < n; i++) {
        if (s[i] == '"' || s[i] == '\\') printf("\\%c", s[i]);
        else if (s[i] < 0x20) printf("\\u%04x", s[i]);
        else putchar(s[i]);
    }
}

static void lod_pair(const swpm_file *f, uint64_t target, int first) {
    printf("%s[%llu,%llu]", first ? "" : ",", (unsigned long long)target,
           (unsigned long long)swpm_lod_for_triangles(f, target));
}

/* Every buffer the reader sees sits at an odd address, ending exactly at the allocation's end (so that a read
 * past it trips the address sanitizer): the file's bytes may be anywhere in an engine's memory, and UBSan
 * (-fsanitize=undefined includes alignment) then reports any load through a casted pointer. */
/* The end of an instance step's row: the dirty range taken, the drawn bytes as hex for a short file. */
static void step_end(uint64_t first, uint64_t end, const uint8_t *buffer, uint64_t bytes, uint64_t L) {
    printf(",%llu,%llu", (unsigned long long)first, (unsigned long long)end);
    if (L <= 8) {
        printf(",\"");
        hex(buffer, bytes);
        printf("\"");
    }
    printf("]");
}

static void *odd_alloc(size_t n) {
    uint8_t *p = (uint8_t *)malloc(n + 1);
    return p ? p + 1 : NULL;
}
static void odd_free(void *p) {
    if (p) free((uint8_t *)p - 1);
}

/* Read a whole file into a buffer of exactly its size (so that a read past the end trips the address
 * sanitizer); NULL if it cannot. */
static uint8_t *read_file(const char *path, size_t *size) {
    FILE *fp = fopen(path, "rb");
    long n;
    uint8_t *data;
    if (!fp) return NULL;
    if (fseek(fp, 0, SEEK_END) != 0 || (n = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET) != 0) {
        fclose(fp);
        return NULL;
    }
    data = (uint8_t *)odd_alloc((size_t)n);
    if (data && fread(data, 1, (size_t)n, fp) != (size_t)n) {
        odd_free(data);
        data = NULL;
    }
    fclose(fp);
    *size = (size_t)n;
    return data;
}

static void print_result(swpm_result r) {
    if (!r.code) {
        printf("{\"ok\":true}\n");
        return;
    }
    printf("{\"ok\":false,\"code\":\"%s\",\"offset\":", r.code);
    if (r.has_offset) printf("%llu", (unsigned long long)r.offset);
    else printf("null");
    if (r.need) printf(",\"need\":%llu", (unsigned long long)r.need);
    printf("}\n");
}

/* swpm_open_ex with a scratch of exactly `scratch_bytes` bytes (-1: the file's length), allocated apart so
 * that the address sanitizer sees a replay that writes past it. */
static swpm_result open_with_scratch(const uint8_t *d, size_t n, swpm_file *f, long long scratch_bytes) {
    size_t s = scratch_bytes < 0 ? n : (size_t)scratch_bytes;
    void *scratch = odd_alloc(s);
    swpm_result r = swpm_open_ex(d, n, f, scratch, scratch ? s : 0);
    odd_free(scratch);
    return r;
}

static void result_fields(swpm_result r) {
    printf("\"ok\":%s", r.code ? "false" : "true");
    if (!r.code) return;
    printf(",\"code\":\"%s\",\"offset\":", r.code);
    if (r.has_offset) printf("%llu", (unsigned long long)r.offset);
    else printf("null");
    if (r.need) printf(",\"need\":%llu", (unsigned long long)r.need);
    if (r.need_start) printf(",\"need_start\":%llu", (unsigned long long)r.need_start);
}

/* The CRC-32 state c continued over the points of vertices [0, n) through swpm_point, as f32 little-endian */
static uint32_t points_crc_update(uint32_t c, const swpm_file *f, uint64_t n) {
    uint32_t u, j;
    uint64_t k;
    for (k = 0; k < n; k++) {
        float xyz[3];
        uint8_t le[12];
        swpm_point(f, (uint32_t)k, xyz);
        for (j = 0; j < 3; j++) {
            memcpy(&u, &xyz[j], 4);
            le[4 * j] = (uint8_t)u, le[4 * j + 1] = (uint8_t)(u >> 8);
            le[4 * j + 2] = (uint8_t)(u >> 16), le[4 * j + 3] = (uint8_t)(u >> 24);
        }
        c = swpm__crc_update(c, le, 12);
    }
    return c;
}
/* CRC-32 of the points of vertices [0, n) */
static uint32_t points_crc(const swpm_file *f, uint64_t n) { return points_crc_update(0xFFFFFFFFu, f, n) ^ 0xFFFFFFFFu; }

/* a finished prefix's or ranges' "whole_crc": every point and the index pool, read through f's views */
static void whole_crc(const swpm_file *f) {
    uint64_t count;
    uint32_t width;
    const uint8_t *pool = swpm_index_pool(f, &count, &width);
    printf(",\"whole_crc\":[%lu,%lu]", (unsigned long)points_crc(f, swpm_vertex_count(f)),
           (unsigned long)(swpm__crc_update(0xFFFFFFFFu, pool, count * width) ^ 0xFFFFFFFFu));
}

/* --ranges OFF:LEN,... [--fill HH] FILE: see the top of the file. */
static int ranges(int argc, char **argv) {
    size_t size, top = 0, nh = 0, i;
    swpm_range held[64];
    swpm_file f;
    swpm_result r;
    uint8_t *buf, *whole;
    void *scratch;
    const char *spec = argv[2];
    int fill = 0;
    uint8_t *data = read_file(argv[argc - 1], &size);
    if (!data) {
        fprintf(stderr, "swpm_dump: cannot read %s\n", argv[argc - 1]);
        return 2;
    }
    if (argc >= 6 && strcmp(argv[3], "--fill") == 0) fill = (int)strtol(argv[4], NULL, 16);
    while (*spec) { /* OFF:LEN pairs, comma-separated; a malformed one or one past the file: usage (2) */
        char *end, *colon;
        unsigned long long off, len;
        off = strtoull(spec, &colon, 10);
        end = colon;
        len = *colon == ':' && colon != spec ? strtoull(colon + 1, &end, 10) : 0;
        if (*colon != ':' || colon == spec || end == colon + 1 || (*end && *end != ',') || nh == 64 ||
            off > size || len > size - off) {
            fprintf(stderr, "swpm_dump: --ranges item %.*s: not OFF:LEN within the file's %zu bytes"
                    " (at most 64 ranges)\n", (int)strcspn(spec, ","), spec, size);
            odd_free(data);
            return 2;
        }
        held[nh].offset = off;
        held[nh].length = len;
        if (off + len > top) top = (size_t)(off + len);
        nh++;
        spec = *end == ',' ? end + 1 : end;
    }
    /* a fresh buffer up to the last held byte: the held ranges copied, the rest `fill` (never read) */
    buf = (uint8_t *)odd_alloc(top);
    if (top) memset(buf, fill, top);
    for (i = 0; i < nh; i++)
        if (held[i].length) memcpy(buf + held[i].offset, data + held[i].offset, (size_t)held[i].length);
    scratch = odd_alloc(size);
    r = swpm_open_ranges(buf, top, held, nh, &f, scratch, scratch ? size : 0);
    printf("{");
    result_fields(r);
    if (!r.code) {
        uint64_t L = swpm_lod_count(&f), k, nd = 0, count, first;
        uint32_t c = 0xFFFFFFFFu, width;
        const uint8_t *pool = swpm_index_pool(&f, &count, &width);
        swpm_range need[3];
        uint32_t n, j;
        printf(",\"lod_count\":%llu,\"finest\":%llu,\"drawable\":[", (unsigned long long)L,
               (unsigned long long)swpm_finest_drawable_lod(&f));
        for (k = 0; k < L; k++) {
            if (!swpm_lod_drawable(&f, k)) continue;
            printf("%s%llu", nd++ ? "," : "", (unsigned long long)k);
            /* the drawn arrays: points of its vertices (f32 LE), then its INDX elements as stored */
            c = points_crc_update(c, &f, swpm_lod_vertex_count(&f, k));
            swpm_lod_index_range(&f, k, &first, &count);
            c = swpm__crc_update(c, pool + first * width, count * width);
        }
        printf("],\"drawn_crc\":%lu,\"needed\":[", (unsigned long)(c ^ 0xFFFFFFFFu));
        for (k = 0; k < L; k += L - 1 > 0 ? L - 1 : 1) { /* LOD 0 and L-1 */
            n = swpm_lod_needed_ranges(&f, k, need);
            printf("%s[", k ? "," : "");
            for (j = 0; j < n; j++)
                printf("%s%llu,%llu", j ? "," : "", (unsigned long long)need[j].offset,
                       (unsigned long long)need[j].length);
            printf("]");
        }
        whole = (uint8_t *)odd_alloc(size);
        if (size) memcpy(whole, data, size);
        printf("],\"finish\":{");
        r = swpm_ranges_finish(&f, whole, size, scratch, scratch ? size : 0);
        result_fields(r);
        printf("}");
        odd_free(buf); /* finished, f views `whole` (ASan: a stale view trips) */
        buf = NULL;
        if (!r.code) whole_crc(&f);
        odd_free(whole);
    }
    printf("}\n");
    odd_free(buf);
    odd_free(scratch);
    odd_free(data);
    return 0;
}

/* --prefix: see the top of the file. */
static int prefixes(int argc, char **argv) {
    size_t size, n;
    int a;
    uint8_t *data = read_file(argv[argc - 1], &size);
    if (!data) {
        fprintf(stderr, "swpm_dump: cannot read %s\n", argv[argc - 1]);
        return 2;
    }
    for (a = 2; a < argc - 1; a++) {
        swpm_file f;
        swpm_result r;
        uint8_t *part, *whole;
        void *scratch = odd_alloc(size);
        uint64_t L, fin, count, b;
        uint32_t width;
        const uint8_t *pool;
        long long want = atoll(argv[a]);
        n = want < 0 || (unsigned long long)want > size ? size : (size_t)want;
        part = (uint8_t *)odd_alloc(n);
        if (n) memcpy(part, data, n);
        r = swpm_open_prefix(part, n, &f, scratch, scratch ? size : 0);
        printf("{\"n\":%llu,", (unsigned long long)n);
        result_fields(r);
        if (!r.code) {
            L = swpm_lod_count(&f);
            fin = swpm_finest_drawable_lod(&f);
            printf(",\"file_size\":%llu,\"lod_count\":%llu,\"finest\":%llu,\"needed\":[%llu,%llu,%llu]",
                   (unsigned long long)swpm_file_size(&f), (unsigned long long)L, (unsigned long long)fin,
                   (unsigned long long)swpm_lod_needed_bytes(&f, 0),
                   (unsigned long long)swpm_lod_needed_bytes(&f, fin < L ? fin : L - 1),
                   (unsigned long long)swpm_lod_needed_bytes(&f, L - 1));
            if (fin < L && swpm_lod_drawable(&f, fin)) {
                printf(",\"points_crc\":%lu", (unsigned long)points_crc(&f, swpm_lod_vertex_count(&f, fin)));
            } else {
                printf(",\"points_crc\":null");
            }
            pool = swpm_index_pool(&f, &count, &width);
            printf(",\"pool_crc\":%lu,\"smap\":[",
                   (unsigned long)(swpm__crc_update(0xFFFFFFFFu, pool, count * width) ^ 0xFFFFFFFFu));
            for (b = 0; b < swpm_smap_band_count(&f); b++) {
                uint32_t first, lods, ranges, i;
                uint64_t plen, ro, rl;
                swpm_smap_band(&f, b, &first, &lods, &ranges, &plen);
                printf("%s[%u,%u,%u,%llu", b ? "," : "", first, lods, ranges, (unsigned long long)plen);
                for (i = 0; i < ranges && swpm_smap_range(&f, b, i, &ro, &rl); i++)
                    printf(",%llu,%llu", (unsigned long long)ro, (unsigned long long)rl);
                printf("]");
            }
            whole = (uint8_t *)odd_alloc(size);
            if (size) memcpy(whole, data, size);
            printf("],\"finish\":{");
            r = swpm_prefix_finish(&f, whole, size);
            result_fields(r);
            printf("}");
            odd_free(part); /* finished, f views `whole`: the prefix's buffer may go (ASan: a stale view trips) */
            part = NULL;
            if (!r.code) whole_crc(&f); /* every point and the index pool, through the moved views */
            odd_free(whole);
        }
        printf("}\n");
        odd_free(part);
        odd_free(scratch);
    }
    odd_free(data);
    return 0;
}

static const char *const encodings[5] = {"", "vanilla", "sliding-window", "skip-strip", "mixed"};

/* skip-strip and mixed: the summary's arrays, then "levels" (swpm_level_at of each level) and "instance":
 * an instance moved to LODs 0, 1, ..., L-1 and back to 0, each step [lod, level, index_count, vertex_count,
 * the CRC-32 of the buffer's first index_count indices as stored (mixed: then static_first, static_count),
 * the dirty range taken (first, end), and when L <= 8 the hex of those indices]; the caller's printf goes on with "lod_for_triangles". */
static void levels(const swpm_file *f) {
    static const char *const skip_names[6] = {"level_first_lod", "level_index_start", "level_collapsed_start",
                                              "level_record_start", "level_collapsed_indices", ""};
    static const char *const mixed_names[6] = {"level_first_lod",     "level_static_start",
                                               "level_dynamic_start", "level_record_start",
                                               "level_dynamic_indices", "level_dynamic_collapsed_indices"};
    static const char *const skip_cols[4] = {"collapse_kept", "collapse_binned", "collapse_change_count",
                                             "collapse_prev_change_count"};
    static const char *const mixed_cols[5] = {"collapse_kept", "collapse_static_tris_removed",
                                              "collapse_dynamic_tris_removed", "collapse_change_count",
                                              "collapse_prev_change_count"};
    const int mixed = swpm_encoding(f) == 4;
    const uint32_t O = swpm_offset_width(f);
    uint64_t count, R, M, L = swpm_lod_count(f), pos, bytes, l;
    uint32_t width, row, c;
    const uint8_t *p;
    swpm_level_instance inst;
    uint8_t *buffer;
    int which;
    p = swpm_index_pool(f, &count, &width);
    array(mixed ? "level_static_indices" : "level_indices", p, count, width, width, count, 0, 0);
    for (which = 0; which < (mixed ? 6 : 5); which++) {
        p = swpm_level_array(f, which, &count, &width);
        array(mixed ? mixed_names[which] : skip_names[which], p, count, width, width, count, 0, 0);
    }
    p = swpm_collapse_records(f, &R, &row);
    for (c = 0; c < row / O; c++) array(mixed ? mixed_cols[c] : skip_cols[c], p + c * O, R, row, O, R, 0, 0);
    p = swpm_collapse_change_offsets(f, &M);
    array("collapse_change_offsets", p, M, O, O, M, 0, 0);
    p = swpm_lod_record_counts(f, &count);
    array("lod_record_counts", p, count, O, O, count, 0, 0);
    printf("},\"levels\":[");
    for (l = 0; l < swpm_level_count(f); l++) {
        swpm_level v;
        swpm_level_at(f, l, &v);
        printf("%s[%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu]", l ? "," : "", (unsigned long long)v.first_lod,
               (unsigned long long)v.lod_end, (unsigned long long)v.record_start, (unsigned long long)v.record_end,
               (unsigned long long)v.index_start, (unsigned long long)v.index_count,
               (unsigned long long)v.dynamic_start, (unsigned long long)v.dynamic_count);
    }
    printf("],\"level_of_lod\":[");
    for (pos = 0; pos < L; pos++) printf("%s%llu", pos ? "," : "", (unsigned long long)swpm_level_of_lod(f, pos));
    printf("],\"instance\":[");
    bytes = swpm_level_instance_bytes(f);
    buffer = (uint8_t *)odd_alloc((size_t)bytes);
    if (!buffer || !(mixed ? swpm_mixed_instance_init(f, &inst, buffer, bytes)
                           : swpm_skip_instance_init(f, &inst, buffer, bytes))) {
        fprintf(stderr, "swpm_dump: no instance\n");
        exit(2);
    }
    width = swpm_index_width(f);
    for (pos = 0; pos < 2 * L - 1; pos++) { /* 0, 1, ..., L-1, L-2, ..., 0 */
        uint64_t lod = pos < L ? pos : 2 * L - 2 - pos, n, sf = 0, sc = 0, first, end;
        uint32_t vertex_count;
        n = mixed ? swpm_mixed_set_lod(f, &inst, lod, &sf, &sc, &vertex_count)
                  : swpm_skip_set_lod(f, &inst, lod, &vertex_count);
        printf("%s[%llu,%llu,%llu,%u,%lu", pos ? "," : "", (unsigned long long)lod, (unsigned long long)inst.level,
               (unsigned long long)n, vertex_count,
               (unsigned long)(swpm__crc_update(0xFFFFFFFFu, buffer, n * width) ^ 0xFFFFFFFFu));
        if (mixed) printf(",%llu,%llu", (unsigned long long)sf, (unsigned long long)sc);
        swpm_level_take_dirty(&inst, &first, &end);
        step_end(first, end, buffer, n * width, L);
    }
    odd_free(buffer);
    printf("],\"lod_for_triangles\":[");
}

int main(int argc, char **argv) {
    uint8_t *data;
    size_t size;
    swpm_file f;
    swpm_result r;
    uint64_t L, k, count, restart;
    uint32_t i, width, stride, row;
    const uint8_t *p;

    if (argc >= 2 && (strcmp(argv[1], "--check") == 0 || strcmp(argv[1], "--check-scratch") == 0)) {
        int a, first = 2;
        long long scratch_bytes = -1;
        if (strcmp(argv[1], "--check-scratch") == 0) {
            if (argc < 3) return 2;
            scratch_bytes = atoll(argv[2]);
            first = 3;
        }
        for (a = first; a < argc; a++) {
            size_t n;
            uint8_t *d = read_file(argv[a], &n);
            if (!d) {
                fprintf(stderr, "swpm_dump: cannot read %s\n", argv[a]);
                return 2;
            }
            print_result(open_with_scratch(d, n, &f, scratch_bytes));
            odd_free(d);
        }
        return 0;
    }
    if (argc >= 4 && strcmp(argv[1], "--prefix") == 0) return prefixes(argc, argv);
    if (argc >= 4 && strcmp(argv[1], "--ranges") == 0) return ranges(argc, argv);
    if (argc != 2) {
        fprintf(stderr, "usage: swpm_dump FILE | swpm_dump --check FILE... | swpm_dump --prefix N... FILE | "
                        "swpm_dump --ranges OFF:LEN,... [--fill HH] FILE\n");
        return 2;
    }
    data = read_file(argv[1], &size);
    if (!data) {
        fprintf(stderr, "swpm_dump: cannot read %s\n", argv[1]);
        return 2;
    }
    r = open_with_scratch(data, size, &f, -1);
    if (r.code) {
        print_result(r);
        odd_free(data);
        return 1;
    }
    L = swpm_lod_count(&f);
    printf("{\"ok\":true,\"encoding\":\"%s\",\"features\":%u,\"index_width\":%u,\"offset_width\":%u,",
           encodings[swpm_encoding(&f)], swpm_features(&f), swpm_index_width(&f), swpm_offset_width(&f));
    printf("\"primitive_strip\":%d,", swpm_primitive_strip(&f));
    printf("\"lod_count\":%llu,\"vertex_count\":%u,\"triangle_count\":%u,", (unsigned long long)L,
           swpm_vertex_count(&f), swpm_lod_triangle_count(&f, 0));
    printf("\"restart_index\":");
    if (swpm_restart_index(&f, &restart)) printf("%llu,", (unsigned long long)restart);
    else printf("null,");
    printf("\"points_getter\":\""); /* swpm_point's floats, as little-endian hex */
    for (i = 0; i < swpm_vertex_count(&f); i++) {
        float xyz[3];
        uint32_t c, u;
        uint8_t le[4];
        swpm_point(&f, i, xyz);
        for (c = 0; c < 3; c++) {
            memcpy(&u, &xyz[c], 4);
            le[0] = (uint8_t)u, le[1] = (uint8_t)(u >> 8), le[2] = (uint8_t)(u >> 16), le[3] = (uint8_t)(u >> 24);
            hex(le, 4);
        }
    }
    printf("\",");
    printf("\"arrays\":{");
    p = swpm_points(&f, &stride);
    array("points", p, swpm_vertex_count(&f), stride, 12, swpm_vertex_count(&f), 3, 1);
    for (i = 0; i < swpm_attribute_count(&f); i++) {
        swpm_attribute a;
        swpm_attribute_at(&f, i, &a);
        printf(",\"attribute:");
        json_chars(a.name, a.name_length);
        printf("\":{\"shape\":[%u,%u],\"hex\":\"", swpm_vertex_count(&f), a.components);
        for (k = 0; k < swpm_vertex_count(&f); k++) hex(a.data + k * stride, (uint64_t)a.components * a.elem_size);
        printf("\"}");
    }
    array("vertex_counts", f.lods, L, 12, 4, L, 0, 0);
    array("triangle_counts", f.lods + 4, L, 12, 4, L, 0, 0);
    array("lod_errors", f.lods + 8, L, 12, 4, L, 0, 0);
    p = swpm_index_pool(&f, &count, &width);
    if (swpm_encoding(&f) == 3 || swpm_encoding(&f) == 4) {
        levels(&f);
        goto lod_pairs;
    }
    if (swpm_encoding(&f) == 1) {
        static const char *columns[4] = {"collapse_kept", "collapse_tris_removed", "collapse_change_count",
                                         "collapse_prev_change_count"};
        uint32_t O = swpm_offset_width(&f), c;
        uint64_t R, M, pos, ibytes = count * width;
        swpm_vanilla_instance inst;
        uint8_t *buffer;
        array("indices", p, count, width, width, count, 0, 0);
        p = swpm_collapse_records(&f, &R, &row);
        for (c = 0; c < 4; c++) array(columns[c], p + c * O, R, row, O, R, 0, 0);
        p = swpm_collapse_change_offsets(&f, &M);
        array("collapse_change_offsets", p, M, O, O, M, 0, 0);
        p = swpm_lod_record_counts(&f, &count);
        array("lod_record_counts", p, count, O, O, count, 0, 0);
        printf("},\"instance\":[");
        buffer = (uint8_t *)odd_alloc((size_t)ibytes);
        if (!buffer || !swpm_vanilla_instance_init(&f, &inst, buffer, ibytes)) {
            fprintf(stderr, "swpm_dump: no instance\n");
            return 2;
        }
        for (pos = 0; pos < 2 * L - 1; pos++) { /* 0, 1, ..., L-1, L-2, ..., 0 */
            uint64_t lod = pos < L ? pos : 2 * L - 2 - pos, n, first, end;
            uint32_t vertex_count;
            n = swpm_vanilla_set_lod(&f, &inst, lod, &vertex_count);
            printf("%s[%llu,%llu,%u,%lu", pos ? "," : "", (unsigned long long)lod, (unsigned long long)n,
                   vertex_count, (unsigned long)(swpm__crc_update(0xFFFFFFFFu, buffer, n * width) ^ 0xFFFFFFFFu));
            swpm_vanilla_take_dirty(&inst, &first, &end);
            step_end(first, end, buffer, n * width, L);
        }
        odd_free(buffer);
        printf("],\"lod_for_triangles\":[");
        goto lod_pairs;
    }
    array("index_pool", p, count, width, width, count, 0, 0);
    p = swpm_window_records(&f, &row);
    array("window_records", p, L, row, 3 * (uint64_t)swpm_offset_width(&f), L, 3, 0);
    if (swpm_features(&f) & SWPM_FEATURE_SW_STRIPS)
        array("window_index_counts", p + 3 * swpm_offset_width(&f), L, row, swpm_offset_width(&f), L, 0, 0);
    printf("},\"windows\":[");
    for (k = 0; k < L; k++) {
        uint64_t first_index, index_count;
        uint32_t vertex_count;
        swpm_window(&f, k, &first_index, &index_count, &vertex_count);
        printf("%s[%llu,%llu,%u]", k ? "," : "", (unsigned long long)first_index, (unsigned long long)index_count,
               vertex_count);
    }
    printf("],\"lod_for_triangles\":[");
lod_pairs:
    lod_pair(&f, 0, 1);
    for (k = 0; k < L; k++) {
        uint64_t t = swpm_lod_triangle_count(&f, k);
        lod_pair(&f, t, 0);
        lod_pair(&f, t + 1, 0);
        if (t) lod_pair(&f, t - 1, 0);
    }
    lod_pair(&f, UINT64_MAX, 0);
    /* swpm_lod_for_error at 0, every LOD's error, midway to the next one, and far past the last */
    printf("],\"lod_for_error\":[[0,%llu]", (unsigned long long)swpm_lod_for_error(&f, 0.0));
    for (k = 0; k < L; k++) {
        double e = (double)swpm_lod_error(&f, k), next = k + 1 < L ? (double)swpm_lod_error(&f, k + 1) : 2 * e + 1;
        printf(",[%.17g,%llu]", e, (unsigned long long)swpm_lod_for_error(&f, e));
        printf(",[%.17g,%llu]", e + (next - e) / 2, (unsigned long long)swpm_lod_for_error(&f, e + (next - e) / 2));
    }
    printf(",[1e300,%llu]]}\n", (unsigned long long)swpm_lod_for_error(&f, 1e300));
    odd_free(data);
    return 0;
}
