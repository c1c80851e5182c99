/*
 * c_far_range FILE FAR BYTE: tests/test_ranges_c.py's check that swpm_open_ranges reads no byte it does not
 * hold, however far apart the held ranges lie (format.md 4.2; the corrupt-file promise of format.md 5). FILE
 * (valid, in streaming order) gets a header claiming file_size 2 FAR (file CRC recomputed) and is held whole
 * with 16 more bytes at FAR (BYTE, then zeros: trailing padding of the claimed file). The buffer is FAR + 16
 * bytes of virtual memory, not readable but for the pages of the held bytes: a byte read between the
 * ranges faults (SIGSEGV; under ASan a SEGV report). One JSON line: {"code" (null: opened), "offset",
 * "drawable" (when opened)}. Exit 2 on I/O, a bad argument or a refused mapping.
 */
#define _DEFAULT_SOURCE /* mmap's MAP_ANONYMOUS and MAP_NORESERVE */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#define SWPM_READER_IMPLEMENTATION
#include "swpm_reader.h"

int main(int argc, char **argv) {
    FILE *fp;
    uint8_t *data, *buf, zero4[4] = {0, 0, 0, 0};
    long size;
    uint64_t far, table_end, k, n = 0;
    uint32_t crc;
    size_t page = (size_t)sysconf(_SC_PAGESIZE);
    swpm_range held[2];
    swpm_file f;
    swpm_result r;
    void *scratch;
    if (argc != 4 || !(fp = fopen(argv[1], "rb"))) return 2;
    far = strtoull(argv[2], NULL, 10);
    fseek(fp, 0, SEEK_END);
    size = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    data = (uint8_t *)malloc((size_t)size);
    if (size < 64 || far % page || far < (uint64_t)size || !data || fread(data, 1, (size_t)size, fp) != (size_t)size)
        return 2;
    fclose(fp);
    for (k = 0; k < 8; k++) data[40 + k] = (uint8_t)((2 * far) >> (8 * k)); /* file_size 2 FAR */
    table_end = swpm__u64(data + 32) + 32 * (uint64_t)swpm__u32(data + 24);
    crc = swpm__crc_update(0xFFFFFFFFu, data, 48);
    crc = swpm__crc_update(crc, zero4, 4);
    crc = swpm__crc_update(crc, data + 52, table_end - 52) ^ 0xFFFFFFFFu;
    for (k = 0; k < 4; k++) data[48 + k] = (uint8_t)(crc >> (8 * k));
    buf = (uint8_t *)mmap(NULL, (size_t)far + 16, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (buf == MAP_FAILED || mprotect(buf, (size_t)size, PROT_READ | PROT_WRITE) ||
        mprotect(buf + far, 16, PROT_READ | PROT_WRITE))
        return 2;
    memcpy(buf, data, (size_t)size);
    buf[far] = (uint8_t)strtoul(argv[3], NULL, 16);
    held[0].offset = 0;
    held[0].length = (uint64_t)size;
    held[1].offset = far;
    held[1].length = 16;
    scratch = malloc((size_t)size);
    r = swpm_open_ranges(buf, (size_t)far + 16, held, 2, &f, scratch, (size_t)size);
    printf("{\"code\":");
    if (r.code) printf("\"%s\"", r.code);
    else printf("null");
    printf(",\"offset\":%llu", (unsigned long long)r.offset);
    if (!r.code) {
        printf(",\"drawable\":[");
        for (k = 0; k < swpm_lod_count(&f); k++)
            if (swpm_lod_drawable(&f, k)) printf("%s%llu", n++ ? "," : "", (unsigned long long)k);
        printf("]");
    }
    printf("}\n");
    free(scratch);
    free(data);
    munmap(buf, (size_t)far + 16);
    return 0;
}
