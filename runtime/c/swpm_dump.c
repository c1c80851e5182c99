/*
 * swpm_dump FILE: open a sliding-window SWPM file with swpm_reader.h and print one JSON object.
 * Rejected: {"ok": false, "code": ..., "offset": N or null}, exit 1. Accepted: {"ok": true, the header
 * fields, "arrays": every array of the sliding-window summary (spec/format.md 7) as the lowercase hex of its
 * elements in C order in their stored type, little-endian, "windows": swpm_window of every LOD,
 * "lod_for_triangles": [target, LOD] pairs}, exit 0. Usage error: exit 2.
 * swpm_dump --check FILE...: one line per file, {"ok": ...} or {"ok": false, "code", "offset"} (a batch
 * for tests: one process for thousands of files); exit 0, 2 when a file cannot be read.
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
    data = (uint8_t *)malloc(n ? (size_t)n : 1);
    if (data && fread(data, 1, (size_t)n, fp) != (size_t)n) {
        free(data);
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
    if (r.has_offset) printf("%llu}\n", (unsigned long long)r.offset);
    else printf("null}\n");
}

int main(int argc, char **argv) {
    uint8_t *data;
    size_t size;
    swpm_file f;
    swpm_result r;
    uint64_t L, k, count, restart;
    uint32_t i, width, stride, row;
    const uint8_t *p;

    if (argc >= 2 && strcmp(argv[1], "--check") == 0) {
        int a;
        for (a = 2; a < argc; a++) {
            size_t n;
            uint8_t *d = read_file(argv[a], &n);
            if (!d) {
                fprintf(stderr, "swpm_dump: cannot read %s\n", argv[a]);
                return 2;
            }
            print_result(swpm_open(d, n, &f));
            free(d);
        }
        return 0;
    }
    if (argc != 2) {
        fprintf(stderr, "usage: swpm_dump FILE | swpm_dump --check FILE...\n");
        return 2;
    }
    data = read_file(argv[1], &size);
    if (!data) {
        fprintf(stderr, "swpm_dump: cannot read %s\n", argv[1]);
        return 2;
    }
    r = swpm_open(data, size, &f);
    if (r.code) {
        printf("{\"ok\":false,\"code\":\"%s\",\"offset\":", r.code);
        if (r.has_offset) printf("%llu}\n", (unsigned long long)r.offset);
        else printf("null}\n");
        free(data);
        return 1;
    }
    L = swpm_lod_count(&f);
    printf("{\"ok\":true,\"encoding\":\"sliding-window\",\"features\":%u,\"index_width\":%u,\"offset_width\":%u,",
           swpm_features(&f), swpm_index_width(&f), swpm_offset_width(&f));
    printf("\"lod_count\":%llu,\"vertex_count\":%u,\"triangle_count\":%u,", (unsigned long long)L,
           swpm_vertex_count(&f), swpm_lod_triangle_count(&f, 0));
    printf("\"restart_index\":");
    if (swpm_restart_index(&f, &restart)) printf("%llu,", (unsigned long long)restart);
    else printf("null,");
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
    lod_pair(&f, 0, 1);
    for (k = 0; k < L; k++) {
        uint64_t t = swpm_lod_triangle_count(&f, k);
        lod_pair(&f, t, 0);
        lod_pair(&f, t + 1, 0);
        if (t) lod_pair(&f, t - 1, 0);
    }
    lod_pair(&f, UINT64_MAX, 0);
    printf("]}\n");
    free(data);
    return 0;
}
