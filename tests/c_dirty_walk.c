/*
 * c_dirty_walk FILE SEED STEPS: tests/test_c_reader.py's check of the instances' dirty ranges
 * (swpm_vanilla_take_dirty, swpm_level_take_dirty). An instance of the file's encoding (vanilla, skip-strip,
 * mixed) takes a random walk of set_lod calls (steps of 1-3 LODs, jumps anywhere, repeats of its LOD); after
 * init and after each call only the dirty range is copied into a mirror, the "GPU" copy, which must then
 * equal the whole instance buffer. Prints one JSON object: "steps", "mismatch" (steps whose mirror differs),
 * "repeat" / "repeat_dirty" (set_lod calls to the held LOD, and those that left a non-empty range),
 * "uploaded" (dirty bytes summed over the steps), "drawn" (bytes drawn from the buffer summed), "levels"
 * (steps that changed level). Exit 1 when the file is rejected, 2 on I/O.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SWPM_READER_IMPLEMENTATION
#include "swpm_reader.h"

static uint64_t rng_state;
static uint64_t rng(uint64_t n) { /* xorshift64*, uniform enough for a walk */
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (rng_state * 2685821657736338717ULL >> 11) % n;
}

int main(int argc, char **argv) {
    FILE *fp;
    long size;
    uint8_t *bytes, *ib, *mirror;
    void *scratch;
    swpm_file f;
    swpm_result r;
    swpm_vanilla_instance vi;
    swpm_level_instance li;
    uint64_t L, count, cap, lod = 0, step, steps, first, end, n = 0, sf, sc;
    uint64_t mismatch = 0, repeat = 0, repeat_dirty = 0, uploaded = 0, drawn = 0, levels = 0;
    uint32_t w, used;
    int enc, any;

    if (argc != 4 || !(fp = fopen(argv[1], "rb"))) return 2;
    rng_state = strtoull(argv[2], NULL, 10) * 2 + 1;
    steps = strtoull(argv[3], NULL, 10);
    if (fseek(fp, 0, SEEK_END) != 0 || (size = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET) != 0) return 2;
    bytes = (uint8_t *)malloc((size_t)size + 1);
    if (!bytes || fread(bytes, 1, (size_t)size, fp) != (size_t)size) return 2;
    fclose(fp);
    scratch = malloc((size_t)size + 1);
    r = swpm_open_ex(bytes, (size_t)size, &f, scratch, (size_t)size);
    free(scratch);
    if (r.code) return 1;
    enc = swpm_encoding(&f);
    L = swpm_lod_count(&f);
    swpm_index_pool(&f, &count, &w);
    cap = enc == 1 ? count * w : swpm_level_instance_bytes(&f);
    ib = (uint8_t *)calloc((size_t)cap + 1, 1); /* both zeroed: slots never written agree */
    mirror = (uint8_t *)calloc((size_t)cap + 1, 1);
    if (!ib || !mirror || (enc == 1 && !swpm_vanilla_instance_init(&f, &vi, ib, cap)) ||
        (enc == 3 && !swpm_skip_instance_init(&f, &li, ib, cap)) ||
        (enc == 4 && !swpm_mixed_instance_init(&f, &li, ib, cap)) || (enc != 1 && enc != 3 && enc != 4))
        return 2;
    for (step = 0; step <= steps; step++) { /* step 0: init */
        uint64_t was = lod, level = enc == 1 ? 0 : li.level, kind = rng(4);
        if (step > 0) {
            if (kind == 0) lod = rng(L); /* a jump, maybe across levels; kind 1 keeps the held LOD */
            else if (kind >= 2) { /* a walk of 1-3 LODs either way */
                uint64_t d = 1 + rng(3);
                lod = rng(2) ? (lod + d < L ? lod + d : L - 1) : (lod >= d ? lod - d : 0);
            }
            if (enc == 1) n = swpm_vanilla_set_lod(&f, &vi, lod, &used);
            else if (enc == 3) n = swpm_skip_set_lod(&f, &li, lod, &used);
            else n = swpm_mixed_set_lod(&f, &li, lod, &sf, &sc, &used);
            levels += enc != 1 && li.level != level;
        }
        any = enc == 1 ? swpm_vanilla_take_dirty(&vi, &first, &end) : swpm_level_take_dirty(&li, &first, &end);
        if (any != (first < end) || end * w > cap) mismatch++;
        else if (any) memcpy(mirror + first * w, ib + first * w, (size_t)((end - first) * w));
        if (memcmp(mirror, ib, (size_t)cap) != 0) mismatch++;
        if (step > 0) {
            uploaded += (end - first) * w;
            drawn += n * w;
            if (lod == was) {
                repeat++;
                repeat_dirty += any != 0;
            }
        }
    }
    printf("{\"steps\":%llu,\"mismatch\":%llu,\"repeat\":%llu,\"repeat_dirty\":%llu,\"uploaded\":%llu,"
           "\"drawn\":%llu,\"levels\":%llu}\n",
           (unsigned long long)steps, (unsigned long long)mismatch, (unsigned long long)repeat,
           (unsigned long long)repeat_dirty, (unsigned long long)uploaded, (unsigned long long)drawn,
           (unsigned long long)levels);
    free(mirror);
    free(ib);
    free(bytes);
    return 0;
}
