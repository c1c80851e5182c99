/*
 * c_bad_ranges FILE OFF:LEN,...: tests/test_ranges_c.py's check of the contract swpm_reader.h states for the
 * held ranges of swpm_open_ranges and swpm_ranges_finish (format.md 4.2), on FILE (valid, in streaming
 * order) and the ranges given (a band of SMAP). One JSON line per case: {"case", "code" (null: opened),
 * "offset", "need_start", "need", "drawable" (the LODs swpm_lod_drawable accepts, when opened)}. Cases:
 * "given" (the ranges as given, in a buffer of exactly their last byte), "reversed" (the same ranges listed
 * last to first), "overlapping" (each range also given again from its middle to its end and the first half
 * again: overlaps and abutting pieces), "zero-length" (the ranges and empty ranges at 0, at the buffer's end,
 * past it and at UINT64_MAX), "past-buffer" (one range one byte past the buffer), "wraps" (a range whose
 * offset + length wraps past 2^64), "past-file-size" (the whole file and 8 bytes after it, file_size
 * unchanged, all held), "null-held" (held NULL, count 1), "none-held" (count 0), then finishing "given" with
 * "finish-ok" (the whole file), "finish-differs" (a held byte changed) and "finish-short" (a whole buffer
 * shorter than the last held range). Every buffer is exactly its length at an odd address (ASan: a byte
 * read past it trips). Exit 2 on I/O or a bad argument.
 */
#include <stdint.h>
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

static void show(const char *name, swpm_result r, const swpm_file *f) {
    uint64_t k, n = 0;
    printf("{\"case\":\"%s\",\"code\":", name);
    if (r.code) printf("\"%s\"", r.code);
    else printf("null");
    printf(",\"offset\":%llu,\"need_start\":%llu,\"need\":%llu", (unsigned long long)r.offset,
           (unsigned long long)r.need_start, (unsigned long long)r.need);
    if (!r.code && f) {
        printf(",\"drawable\":[");
        for (k = 0; k < swpm_lod_count(f); k++)
            if (swpm_lod_drawable(f, k)) printf("%s%llu", n++ ? "," : "", (unsigned long long)k);
        printf("]");
    }
    printf("}\n");
}

/* a buffer of exactly `top` bytes holding the file's bytes of `held` inside it (0xAA elsewhere: never read) */
static uint8_t *fill(const uint8_t *data, size_t top, const swpm_range *held, size_t n) {
    uint8_t *buf = (uint8_t *)odd_alloc(top ? top : 1);
    size_t i;
    memset(buf, 0xAA, top ? top : 1);
    for (i = 0; i < n; i++)
        if (held[i].length && held[i].offset <= top && held[i].length <= top - held[i].offset) /* (no wrap) */
            memcpy(buf + held[i].offset, data + held[i].offset, (size_t)held[i].length);
    return buf;
}

static void run(const char *name, const uint8_t *data, size_t top, const swpm_range *held, size_t n,
                void *scratch, size_t scratch_bytes) {
    swpm_file f;
    uint8_t *buf = fill(data, top, held, n);
    swpm_result r = swpm_open_ranges(buf, top, held, n, &f, scratch, scratch_bytes);
    show(name, r, &f);
    odd_free(buf);
}

int main(int argc, char **argv) {
    FILE *fp;
    long size;
    uint8_t *data, *buf, *whole, *longer;
    void *scratch;
    swpm_range given[16], more[48];
    swpm_file f;
    swpm_result r;
    size_t n = 0, i, m, top = 0;
    const char *spec;

    if (argc != 3 || !(fp = fopen(argv[1], "rb"))) return 2;
    if (fseek(fp, 0, SEEK_END) != 0 || (size = ftell(fp)) <= 0 || fseek(fp, 0, SEEK_SET) != 0) return 2;
    data = (uint8_t *)odd_alloc((size_t)size);
    if (!data || fread(data, 1, (size_t)size, fp) != (size_t)size) return 2;
    fclose(fp);
    for (spec = argv[2]; *spec && n < 16;) { /* OFF:LEN pairs, comma-separated, inside the file */
        char *end;
        given[n].offset = strtoull(spec, &end, 10);
        if (*end != ':') return 2;
        given[n].length = strtoull(end + 1, &end, 10);
        if (given[n].offset > (uint64_t)size || given[n].length > (uint64_t)size - given[n].offset) return 2;
        if (given[n].offset + given[n].length > top) top = (size_t)(given[n].offset + given[n].length);
        n++;
        if (*end != ',') break;
        spec = end + 1;
    }
    scratch = odd_alloc((size_t)size);

    run("given", data, top, given, n, scratch, (size_t)size);
    for (i = 0; i < n; i++) more[i] = given[n - 1 - i];
    run("reversed", data, top, more, n, scratch, (size_t)size);
    for (m = 0, i = 0; i < n; i++) { /* each range, its second half again, and its first half again */
        uint64_t half = given[i].length / 2;
        more[m].offset = given[i].offset + half;
        more[m++].length = given[i].length - half;
        more[m++] = given[i];
        more[m].offset = given[i].offset;
        more[m++].length = half + 1 <= given[i].length ? half + 1 : given[i].length;
    }
    run("overlapping", data, top, more, m, scratch, (size_t)size);
    for (m = 0, i = 0; i < n; i++) more[m++] = given[i];
    more[m].offset = 0, more[m++].length = 0;
    more[m].offset = top, more[m++].length = 0;
    more[m].offset = (uint64_t)size + 4096, more[m++].length = 0;
    more[m].offset = UINT64_MAX, more[m++].length = 0;
    run("zero-length", data, top, more, m, scratch, (size_t)size);

    for (m = 0, i = 0; i < n; i++) more[m++] = given[i];
    more[m].offset = top > 0 ? top - 1 : 0, more[m++].length = 2; /* one byte past the buffer */
    run("past-buffer", data, top, more, m, scratch, (size_t)size);
    more[n].offset = UINT64_MAX - 1, more[n].length = 4; /* offset + length wraps */
    run("wraps", data, top, more, n + 1, scratch, (size_t)size);
    longer = (uint8_t *)odd_alloc((size_t)size + 8); /* the file and 8 bytes after file_size, all held */
    memcpy(longer, data, (size_t)size);
    memset(longer + size, 0, 8);
    more[0].offset = 0, more[0].length = (uint64_t)size + 8;
    r = swpm_open_ranges(longer, (size_t)size + 8, more, 1, &f, scratch, (size_t)size);
    show("past-file-size", r, &f);
    odd_free(longer);
    buf = fill(data, top, given, n);
    r = swpm_open_ranges(buf, top, NULL, 1, &f, scratch, (size_t)size);
    show("null-held", r, &f);
    r = swpm_open_ranges(buf, top, given, 0, &f, scratch, (size_t)size);
    show("none-held", r, &f);

    /* finishing: the held ranges' bytes must be the whole file's there */
    whole = (uint8_t *)odd_alloc((size_t)size);
    memcpy(whole, data, (size_t)size);
    r = swpm_open_ranges(buf, top, given, n, &f, scratch, (size_t)size);
    if (!r.code) {
        swpm_file g = f;
        whole[given[n - 1].offset + given[n - 1].length - 1] ^= 0x01; /* a held byte changed */
        show("finish-differs", swpm_ranges_finish(&g, whole, (size_t)size, scratch, (size_t)size), NULL);
        whole[given[n - 1].offset + given[n - 1].length - 1] ^= 0x01;
        g = f;
        show("finish-short", swpm_ranges_finish(&g, whole, top - 1, scratch, (size_t)size), NULL);
        g = f;
        r = swpm_ranges_finish(&g, whole, (size_t)size, scratch, (size_t)size);
        show("finish-ok", r, &g);
    }
    odd_free(whole);
    odd_free(buf);
    odd_free(scratch);
    odd_free(data);
    return 0;
}
