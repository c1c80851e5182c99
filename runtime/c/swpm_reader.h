/*
 * swpm_reader.h -- a single-header C99 reader for SWPM v1 files of all four encodings: sliding-window (list
 * pools and SW_STRIPS strip pools), vanilla, skip-strip (strips or lists) and mixed, u16/u32 idx, OFFSET32;
 * written from spec/format.md and spec/errors.md (Forsyth's VIPM methods, "Comparison of VIPM Methods",
 * Game Programming Gems 2: sliding window, vanilla, skip strips, mixed mode).
 *
 * Use: in exactly one .c file
 *     #define SWPM_READER_IMPLEMENTATION
 *     #include "swpm_reader.h"
 *
 * What it does: swpm_open() validates a file held in the caller's memory as format.md section 5 asks of a
 * reader (header, chunk table, CRC-32s, required chunks, META, LODS, VERT, then the encoding's chunks:
 * sliding-window WREC, INDX, the windows, the vertex prefix property, strip windows' starts and decoded
 * triangle counts; vanilla VREC, RCNT and INDX lengths and counts, LODS against RCNT and the replay of every
 * collapse record; skip-strip SREC, RCNT, INDX and SKIP, the level table, the lists' values and prefix
 * property, the records against the levels, RCNT and LODS, the replay of each level's records against its
 * collapsed list and LODS triangle counts; mixed MREC, RCNT, INDX and MLVL likewise, with its per-level
 * removals and reference-counted replay) and returns the FIRST error in the order of section 5 "Reporting"
 * as its stable code (errors.md) and byte offset. The accessors then give zero-copy views of the caller's
 * bytes: nothing is allocated, nothing is copied, and no byte outside [bytes, bytes + length) is read.
 * Every sum is computed without wrapping (format.md section 1).
 *
 * Replays need working memory. Vanilla's (format.md 3.6: each record's slots hold the binned vertex, then
 * no live triangle uses it) needs a copy of INDX and a count per vertex: no check order avoids that
 * (whether a slot holds the binned vertex depends on every earlier record). Skip-strip's (3.7) needs a copy
 * of the longest list of a level with records; mixed's (3.8) a copy of the longest such dynamic list and a
 * count per vertex. The caller gives scratch memory to swpm_open_ex(): vanilla INDX length + 8 V + 7 bytes,
 * skip-strip W x that list's length, mixed 8 V + W x that list's length + 7; each at most the file's length.
 * A file with records opened with less (swpm_open gives none) is SWPM_READER_SCRATCH_TOO_SMALL, with the
 * bytes needed in swpm_result.need, once every check before the replay has passed.
 *
 * Streaming (format.md 4.1): swpm_open_prefix() opens the first bytes of a file that is still arriving. It
 * checks everything the prefix holds as swpm_open_ex would, with the header's file_size as the end of the
 * file, and leaves to swpm_prefix_finish() (given the whole file) what lies past the prefix: the length,
 * VERT's CRC and the padding after VERT. It needs VERT to be the last chunk (SWPM_PREFIX_NOT_STREAMABLE) and
 * the prefix to hold every byte before VERT's vertex records (SWPM_PREFIX_TOO_SHORT, with the bytes to wait
 * for in swpm_result.need). LOD k draws once swpm_lod_needed_bytes(k) bytes are held: swpm_finest_drawable_lod
 * gives the finest; the SMAP accessors give the writer's bands and byte ranges, to plan range requests.
 * Byte ranges (format.md 4.2): swpm_open_ranges() opens the ranges of a file the caller holds (SMAP's for a
 * band, HTTP range requests) and reads no other byte, however far apart they lie (tests/c_far_range.c);
 * SWPM_RANGES_NOT_HELD names the range to fetch ([.need_start, .need)); swpm_lod_drawable() says which LODs
 * they draw (not always consecutive), swpm_lod_needed_ranges() what a LOD needs; swpm_ranges_finish() checks
 * the whole file.
 *
 * Per-instance runtime (an engine's): swpm_vanilla_instance_init() / swpm_vanilla_set_lod() (format.md 3.6
 * "At run time": a copy of INDX in the caller's buffer, moved between LODs by applying or undoing collapse
 * records); swpm_skip_instance_init() / swpm_skip_set_lod() and swpm_mixed_instance_init() /
 * swpm_mixed_set_lod() (3.7, 3.8: a copy of the current level's list, or dynamic list, in the caller's
 * buffer of swpm_level_instance_bytes(); a level change copies the target level's stored uncollapsed or
 * collapsed list, whichever is fewer records away, then records are applied or undone). Each instance
 * keeps a dirty range, the slots written since the caller last took it (swpm_vanilla_take_dirty,
 * swpm_level_take_dirty), so an engine re-uploads only [first, end) of its index buffer.
 *
 * What it does not do:
 *  - warnings and infos (SWPM_STREAM_ORDER, SWPM_FILE_TRAILING_BYTES, SWPM_VERT_NONFINITE, ...) are not
 *    reported: a file is accepted iff it has no error;
 *  - SMAP (ancillary, format.md section 4) and unknown ancillary chunks are skipped, not validated;
 *  - META is validated (strict RFC 8259 with the limits of section 3.1) and its params read, but not
 *    exposed as a tree: swpm_meta() gives its bytes.
 *  - Checking a META object for duplicate keys walks the object once per key (O(keys^2) per object):
 *    no allocation, fine for the kilobyte META writers emit.
 *  - it does not decode strips into triangles for the caller: a skip-strip level list is handed to the GPU
 *    as it is (one strip draw, primitive restart at swpm_restart_index, or a list).
 * SWPM_READER_UNSUPPORTED_ENCODING is no longer returned (every encoding is read); the name stays defined.
 */
#ifndef SWPM_READER_H
#define SWPM_READER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Required-feature bits of the header (format.md 2.1). */
#define SWPM_FEATURE_INDEX32 0x01u
#define SWPM_FEATURE_VANILLA 0x02u
#define SWPM_FEATURE_SLIDING_WINDOW 0x04u
#define SWPM_FEATURE_SKIP_STRIP 0x08u
#define SWPM_FEATURE_MIXED 0x10u
#define SWPM_FEATURE_SW_STRIPS 0x20u
#define SWPM_FEATURE_OFFSET32 0x40u

/* The reader's own code for a valid-so-far file of an encoding it did not read (not an errors.md code). Since
 * it reads all four, it no longer returns it; kept for code that tests for it. */
#define SWPM_READER_UNSUPPORTED_ENCODING "SWPM_READER_UNSUPPORTED_ENCODING"
/* The reader's own code for a file whose replay (format.md 5: vanilla stage (c), skip-strip (d), mixed (d))
 * needs more scratch memory than swpm_open_ex was given: swpm_result.need holds the bytes it needs (not an errors.md code; the
 * file is neither accepted nor rejected). */
#define SWPM_READER_SCRATCH_TOO_SMALL "SWPM_READER_SCRATCH_TOO_SMALL"

/* Result of swpm_open: code is NULL on success, else the first error's code string (errors.md); offset is
 * the absolute byte offset it concerns, valid when has_offset is 1 (SWPM_CHUNK_MISSING has none). */
typedef struct swpm_result {
    const char *code;
    uint64_t offset;
    int has_offset;
    uint64_t need; /* SWPM_READER_SCRATCH_TOO_SMALL: the scratch bytes the replay needs; SWPM_PREFIX_TOO_SHORT:
                      the prefix length opening needs (format.md 4.1); SWPM_RANGES_NOT_HELD: the end of the
                      range to fetch (format.md 4.2); else 0 */
    uint64_t need_start; /* SWPM_RANGES_NOT_HELD: the start of that range, [need_start, need); else 0 */
} swpm_result;

/* A byte range [offset, offset + length) of a file that the caller holds (format.md 4.2). */
typedef struct swpm_range {
    uint64_t offset, length;
} swpm_range;

/* One attribute descriptor of VERT (format.md 3.3); name is not NUL-terminated. */
typedef struct swpm_attribute {
    const uint8_t *name;
    uint32_t name_length;
    uint32_t elem_type;   /* 1 u8, 2 i8, 3 u16, 4 i16, 5 u32, 6 i32, 7 f16, 8 f32, 9 f64 */
    uint32_t elem_size;   /* bytes of one element */
    uint32_t components;
    uint32_t offset;      /* inside the vertex record */
    const uint8_t *data;  /* first vertex's value; vertex v's at data + v * stride (may be unaligned) */
} swpm_attribute;

/* An opened file: views into the caller's bytes, valid while they are. Read it through the accessors. */
typedef struct swpm_file {
    const uint8_t *bytes;
    uint64_t length;  /* the end of the file of format.md 1: min(length given, file_size) */
    uint32_t major, minor, features;
    uint32_t index_width, offset_width; /* W and O, from features alone (format.md 1) */
    int strips;                         /* SW_STRIPS */
    uint64_t restart_index;             /* params.restart_index of a strip pool */
    const uint8_t *meta;
    uint64_t meta_length;
    const uint8_t *lods;
    uint64_t lod_count; /* L (u64: LODS may hold more rows than a u32 counts) */
    const uint8_t *vert;
    uint32_t vertex_count, attribute_count, stride, data_offset;
    const uint8_t *wrec;
    const uint8_t *indx;
    uint64_t index_count;
    int encoding;                       /* 1 vanilla, 2 sliding-window, 3 skip-strip, 4 mixed (the bit's index) */
    const uint8_t *vrec;                /* VREC, SREC or MREC's records (R rows of 4 O bytes, MREC 5 O) */
    uint64_t record_count;              /* R */
    uint32_t record_columns;            /* 4, MREC 5 */
    const uint8_t *change_offsets;      /* off[M] */
    uint64_t change_offset_count;       /* M */
    const uint8_t *rcnt;                /* off[L] lod_record_counts */
    /* skip-strip (3.7) and mixed (3.8) */
    int primitive_strip;                /* skip-strip: params.primitive "strip" (the default), not "list" */
    int has_restart;                    /* skip-strip strips with an integer params.restart_index */
    uint64_t level_count;               /* n */
    const uint8_t *level_arrays[4];     /* level_first_lod, then (n+1) each: level_index_start (mixed:
                                           level_static_start), level_collapsed_start (mixed:
                                           level_dynamic_start), level_record_start */
    const uint8_t *level_lists[2];      /* level_collapsed_indices; mixed: level_dynamic_indices and
                                           level_dynamic_collapsed_indices */
    uint64_t level_list_count;          /* C; mixed: D */
    uint64_t longest_list;              /* skip-strip: the longest level list; mixed: dynamic list (elements) */
    /* streaming (format.md 4, 4.1) */
    uint64_t file_size;                 /* the header's file_size */
    uint64_t held;                      /* the bytes given: the prefix's length */
    int prefix;                         /* opened from a prefix shorter than file_size, not finished yet */
    uint64_t vert_entry, vert_offset;   /* VERT's chunk-table entry and payload offsets */
    const uint8_t *smap;                /* SMAP's payload when its length is 8 + 24 B + 16 N, else NULL */
    uint64_t smap_bands, smap_ranges;   /* B, N */
    /* byte ranges (format.md 4.2): the caller's array, read while the file is open from ranges */
    const swpm_range *ranges;           /* NULL unless opened by swpm_open_ranges from a part of the file */
    uint64_t range_count;
    int indx_partial;                   /* ranges without all of INDX: its content checks wait for finishing */
} swpm_file;

/* One vanilla VIPM instance (format.md 3.6): the caller's copy of INDX, which set_lod edits in place. */
typedef struct swpm_vanilla_instance {
    uint8_t *indices;    /* the caller's buffer: 3 T0 elements of W bytes, little-endian, as INDX */
    uint64_t lod;        /* the LOD it holds */
    uint64_t applied;    /* records [0, applied) are applied: RCNT[lod] */
    uint64_t change_pos; /* the sum of their change counts: where record `applied`'s change offsets start */
    uint64_t live;       /* live triangles: LODS triangle_count(lod) */
    uint64_t dirty_first, dirty_end; /* slots [dirty_first, dirty_end) hold every write since the last take */
} swpm_vanilla_instance;

/* Open and validate a file (format.md 5). file is filled only on success. A vanilla, skip-strip or mixed
 * file with records needs scratch memory for its replay: swpm_open gives none, so it answers
 * SWPM_READER_SCRATCH_TOO_SMALL for such a file once every check before the replay has passed; use
 * swpm_open_ex. */
swpm_result swpm_open(const uint8_t *bytes, size_t length, swpm_file *file);
/* swpm_open with scratch memory for the replays (format.md 5: vanilla stage (c), skip-strip (d), mixed (d)):
 * vanilla a copy of INDX (its payload length) and a 64-bit reference count per vertex (8 V), aligned inside
 * the scratch (up to 7 bytes): INDX length + 8 V + 7 bytes; skip-strip a copy of the longest list of a level
 * with records (W x its length, at most INDX length); mixed 8 V + W x the longest dynamic list of a level
 * with records + 7. The file's length always suffices (INDX, the MLVL lists and VERT, whose length is at
 * least 16 + 12 V, are disjoint parts of it). Only a replay uses it, and only in a file with R > 0 (a
 * skip-strip level without records is compared in place); a smaller scratch is
 * SWPM_READER_SCRATCH_TOO_SMALL with .need set, after every earlier check passed (an error found before the
 * replay is reported as usual). scratch may be NULL when scratch_bytes is 0; its contents are clobbered.
 * Nothing is allocated. */
swpm_result swpm_open_ex(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                         size_t scratch_bytes);
/* The encoding bit's index: 1 vanilla, 2 sliding-window, 3 skip-strip, 4 mixed. */
int swpm_encoding(const swpm_file *f);

/* ---- streaming (format.md 4, 4.1): open the first `length` bytes of a file still arriving ---- */
/* swpm_open_ex for a prefix of the file (length < file_size; a whole file is opened as swpm_open_ex opens it).
 * SWPM_PREFIX_TOO_SHORT (.need: the prefix length to wait for) while the prefix ends before VERT's vertex
 * records; SWPM_PREFIX_NOT_STREAMABLE when VERT is not the last chunk; any other error is the file's. On
 * success every accessor works, but only the vertices of drawable LODs (swpm_lod_drawable) lie in the bytes
 * given: an engine reads points and attributes of vertex v < swpm_lod_vertex_count(f, k) of a drawable k. */
swpm_result swpm_open_prefix(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                             size_t scratch_bytes);
/* Complete a prefix opened by swpm_open_prefix with the whole file: `bytes` starts with the same bytes
 * (the same buffer grown, or another: the old one may be freed once this returns). Checks what the prefix
 * could not, in the order of format.md 5 (the length: SWPM_FILE_SIZE_MISMATCH, VERT's CRC, the padding
 * after VERT), so the verdict is the whole file's; on success f views `bytes` (a file opened whole: only
 * that). */
swpm_result swpm_prefix_finish(swpm_file *f, const uint8_t *bytes, size_t length);
int swpm_is_prefix(const swpm_file *f);       /* 1 until swpm_prefix_finish succeeds */
uint64_t swpm_file_size(const swpm_file *f);  /* the header's file_size */
uint64_t swpm_bytes_held(const swpm_file *f); /* the bytes given */
/* The file prefix LOD k needs (format.md 4 (a)+(b)+(c)): VERT's data_offset + vertex_count(k) x stride past
 * VERT's start; non-increasing in k. */
uint64_t swpm_lod_needed_bytes(const swpm_file *f, uint64_t k);
int swpm_lod_drawable(const swpm_file *f, uint64_t k); /* needed bytes held */
/* The finest drawable LOD (the coarsest, L - 1, draws first); L when none is drawable yet. */
uint64_t swpm_finest_drawable_lod(const swpm_file *f);
/* SMAP (format.md 4; ancillary and not validated by this reader: plan range requests with it, decide what
 * draws with swpm_lod_needed_bytes). 0 bands without a SMAP or with one of a wrong length. */
uint64_t swpm_smap_band_count(const swpm_file *f);
int swpm_smap_band(const swpm_file *f, uint64_t b, uint32_t *first_lod, uint32_t *lod_count, uint32_t *range_count,
                   uint64_t *prefix_length); /* 0 if b is out of range */
/* Byte ranges (format.md 4.2): open a file from the ranges the caller holds. `bytes` covers [0, length) of the
 * file (length at least the end of the last held range); only the bytes of held[0..held_count) are the file's,
 * and no other byte of `bytes` is read. The array `held` is read while the file is open from ranges (keep it
 * until swpm_ranges_finish). Checks what the ranges hold as swpm_open_ex would, with the header's file_size
 * as the end of the file: the header and chunk table, every byte before INDX and VERT's bytes before its
 * records must be held (else SWPM_RANGES_NOT_HELD at the first byte not held, with the range to fetch in
 * [.need_start, .need)); CRCs of payloads not wholly held, padding not held and the length wait for finishing;
 * without all of INDX its content checks wait too and each LOD's held INDX elements are checked against the
 * vertices it draws (SWPM_PREFIX_VIOLATION). Every table it decodes must be held too (format.md 4.2: a table
 * after INDX in a file not in streaming order, SWPM_RANGES_NOT_HELD with that chunk's range). A range past
 * `length` or past file_size is the caller's error: SWPM_READER_BAD_RANGES, unless file_size is below 64 (the
 * header then lies past it: the file's error, as format.md 5 reports it from the bytes held).
 * The contract on `held` (tests/c_bad_ranges.c checks each clause): ranges may come in any order, overlap and
 * abut (what counts is the union of their bytes; their order changes no result); a range of length 0 holds
 * no byte and is ignored wherever its offset lies (as Python's open_ranges drops an empty range); a range
 * with offset + length past `length`, past the header's file_size (64 or more), or past 2^64 (wrapping), and
 * `held` NULL with held_count > 0, are SWPM_READER_BAD_RANGES (offset 0; no file is opened); held_count 0
 * holds no byte: SWPM_RANGES_NOT_HELD for [0, 64). */
#define SWPM_READER_BAD_RANGES "SWPM_READER_BAD_RANGES"
swpm_result swpm_open_ranges(const uint8_t *bytes, size_t length, const swpm_range *held, size_t held_count,
                             swpm_file *file, void *scratch, size_t scratch_bytes);
/* Complete ranges opened by swpm_open_ranges with the whole file (swpm_prefix_finish given such a file calls
 * this without scratch) (its bytes in each held range must be the ones held, `length` reaching the end of
 * each, else SWPM_READER_BAD_RANGES): checks it all through, as swpm_open_ex (so the verdict is the
 * whole file's), and on success *f views `bytes` as an opened whole file. */
swpm_result swpm_ranges_finish(swpm_file *f, const uint8_t *bytes, size_t length, void *scratch,
                               size_t scratch_bytes);
int swpm_is_ranges(const swpm_file *f); /* 1 until swpm_ranges_finish succeeds */
/* The INDX elements LOD k draws (format.md 4 (b)): [*first, *first + *count) of swpm_index_pool (vanilla: all;
 * sliding-window: its window; skip-strip: its level's list; mixed: its level's static list). 0 if k >= L. */
int swpm_lod_index_range(const swpm_file *f, uint64_t k, uint64_t *first, uint64_t *count);
/* The byte ranges LOD k needs (format.md 4: (a) [0, INDX), (b) its INDX elements unless none, (c) VERT up to
 * its last vertex record), written to out[0..2]; returns how many (2 or 3), 0 if k >= L. */
uint32_t swpm_lod_needed_ranges(const swpm_file *f, uint64_t k, swpm_range out[3]);
int swpm_smap_range(const swpm_file *f, uint64_t b, uint32_t r, uint64_t *offset, uint64_t *length); /* 0 if out
                                                                                                       of range */

/* Header (2.1): features word, W, O, V, L. */
uint32_t swpm_features(const swpm_file *f);
uint32_t swpm_index_width(const swpm_file *f);
uint32_t swpm_offset_width(const swpm_file *f);
uint32_t swpm_vertex_count(const swpm_file *f);
uint64_t swpm_lod_count(const swpm_file *f);
/* META payload (3.1): UTF-8 JSON, validated; not NUL-terminated. */
const uint8_t *swpm_meta(const swpm_file *f, uint64_t *length);

/* VERT (3.3): points are f32[3] at byte 0 of each record, stride bytes apart, maybe unaligned, little-endian
 * as stored (as GPUs read them: a big-endian host swaps before upload). swpm_point reads one point as floats on
 * any host (IEEE-754 floats of the host's integer byte order). */
const uint8_t *swpm_points(const swpm_file *f, uint32_t *stride);
void swpm_point(const swpm_file *f, uint32_t vertex, float xyz[3]);
uint32_t swpm_attribute_count(const swpm_file *f);
int swpm_attribute_at(const swpm_file *f, uint32_t i, swpm_attribute *out); /* 0 if i is out of range */

/* LODS columns (3.2); k < L. */
uint32_t swpm_lod_vertex_count(const swpm_file *f, uint64_t k);
uint32_t swpm_lod_triangle_count(const swpm_file *f, uint64_t k);
float swpm_lod_error(const swpm_file *f, uint64_t k);

/* INDX (3.4): pointer to the pool as stored (width W bytes, little-endian, maybe unaligned), its count. */
const uint8_t *swpm_index_pool(const swpm_file *f, uint64_t *count, uint32_t *width);
uint32_t swpm_index(const swpm_file *f, uint64_t i);

/* WREC (3.5): row k's fields; index_count is 3 triangle_count for a list pool, the fourth field with
 * SW_STRIPS. Pointer to the table as stored: L rows of 3 O (4 O with SW_STRIPS) bytes. */
const uint8_t *swpm_window_records(const swpm_file *f, uint32_t *row_bytes);
void swpm_window_record(const swpm_file *f, uint64_t k, uint32_t *first_index, uint32_t *triangle_count,
                        uint32_t *vertex_count, uint64_t *index_count);

/* What an engine passes to its draw call for LOD k: INDX[first_index, first_index + index_count) as a
 * triangle list, or with SW_STRIPS as one strip draw with primitive restart (swpm_restart_index), using
 * vertices [0, vertex_count). Returns 0 if lod >= L or the file is not
 * sliding-window (vanilla: swpm_vanilla_set_lod). */
int swpm_window(const swpm_file *f, uint64_t lod, uint64_t *first_index, uint64_t *index_count,
                uint32_t *vertex_count);

/* The finest LOD that draws at most target triangles; the coarsest LOD if none does (README, Python's
 * ProgressiveMesh.lod_for_triangles, whose fractional targets round down; LODS triangle counts are
 * non-increasing, so a binary search). */
uint64_t swpm_lod_for_triangles(const swpm_file *f, uint64_t target);
/* The coarsest LOD whose LODS error is at most max_error (mesh units); LOD 0 if none is, or max_error is NaN
 * (Python's ProgressiveMesh.lod_for_error, which compares each f32 error exactly; errors are non-decreasing,
 * validated: a binary search). Screen-space selection: max_error = max_pixels / (viewport_height / (2 distance
 * tan(fov_y / 2))), in double, as lod_for_screen_error computes it; LOD 0 at distance <= 0. */
uint64_t swpm_lod_for_error(const swpm_file *f, double max_error);

/* ---- vanilla, skip-strip, mixed (format.md 3.4, 3.6-3.8, 7): views of INDX, the record chunk (VREC, SREC,
 * MREC) and RCNT as stored (maybe unaligned); NULL with count 0 for a sliding-window file (whose WREC views
 * are NULL for the others, swpm_window 0) ---- */
/* indices: INDX (vanilla 3 T0 idx values; skip-strip level_indices; mixed level_static_indices):
 * swpm_index_pool. */
/* R records of 4 O bytes (vanilla: kept, tris_removed, change_count, prev_change_count; skip-strip: kept,
 * binned, change_count, prev_change_count), mixed 5 O (swpm_collapse_field); *count = R.
 * swpm_collapse_record reads the four columns of a vanilla or skip-strip record (tris_removed: binned). */
const uint8_t *swpm_collapse_records(const swpm_file *f, uint64_t *count, uint32_t *row_bytes);
void swpm_collapse_record(const swpm_file *f, uint64_t r, uint32_t *kept, uint32_t *tris_removed,
                          uint32_t *change_count, uint32_t *prev_change_count);
/* change_offsets: off[M] slots of INDX (skip-strip: of the record's level list; mixed: of its dynamic
 * list); *count = M. */
const uint8_t *swpm_collapse_change_offsets(const swpm_file *f, uint64_t *count);
/* RCNT: off[L], the records applied at each LOD. */
const uint8_t *swpm_lod_record_counts(const swpm_file *f, uint64_t *count);
uint32_t swpm_lod_record_count(const swpm_file *f, uint64_t k);

/* A vanilla instance (format.md 3.6, "At run time"): copies INDX (3 T0 elements of W bytes) into buffer,
 * which the engine uploads as its index buffer, and sets the instance at LOD 0. Returns 0 (nothing done) if
 * the file is not vanilla or capacity (bytes) is below the INDX length. */
int swpm_vanilla_instance_init(const swpm_file *f, swpm_vanilla_instance *inst, void *buffer, uint64_t capacity);
/* Move the instance to LOD lod (clamped to L-1) by applying records [RCNT[a], RCNT[lod]) in order or undoing
 * records [RCNT[lod], RCNT[a]) from the last (a the LOD it held), editing only the slots those records
 * list; returns the number of indices to draw, the first 3 triangle_count(lod) of the buffer, and sets
 * *vertex_count to LODS vertex_count(lod) (vertices [0, vertex_count) are drawn). */
uint64_t swpm_vanilla_set_lod(const swpm_file *f, swpm_vanilla_instance *inst, uint64_t lod,
                              uint32_t *vertex_count);
/* The dirty range: sets [*first, *end) to the lowest and one past the highest slot (index element, W bytes)
 * written since the last take (init marks the whole buffer), then clears it; returns 0 (first = end = 0)
 * when nothing was written, as after a set_lod to the LOD the instance holds. Uploading those slots keeps a
 * GPU copy of the buffer equal to it. The range may reach past what is drawn (slots of collapsed triangles). */
int swpm_vanilla_take_dirty(swpm_vanilla_instance *inst, uint64_t *first, uint64_t *end);

/* 1 and *restart = params.restart_index (>= V; the largest idx value from current writers) for strips joined
 * by a restart index: a SW_STRIPS pool, skip-strip strips whose restart_index is an integer. 0 otherwise (a
 * list pool; skip-strip lists; skip-strip strips joined by degenerate triangles, restart_index null). */
int swpm_restart_index(const swpm_file *f, uint64_t *restart);
/* 1 if the file's index lists are triangle strips (format.md 3.5, 3.7: SW_STRIPS; skip-strip
 * params.primitive "strip", the default), drawn as one strip draw each (with primitive restart when
 * swpm_restart_index gives one); 0 for triangle lists (vanilla and mixed always). */
int swpm_primitive_strip(const swpm_file *f);

/* ---- skip-strip (format.md 3.7) and mixed (3.8): levels, records, per-instance lists ---- */
/* swpm_level_array's arrays, views of SKIP / MLVL as stored (maybe unaligned): the level table (off,
 * width O) and the lists (idx, width W). */
#define SWPM_LEVEL_FIRST_LOD 0       /* off[n] */
#define SWPM_LEVEL_INDEX_START 1     /* skip-strip level_index_start, off[n+1] */
#define SWPM_LEVEL_STATIC_START 1    /* mixed level_static_start, off[n+1] */
#define SWPM_LEVEL_COLLAPSED_START 2 /* skip-strip level_collapsed_start, off[n+1] */
#define SWPM_LEVEL_DYNAMIC_START 2   /* mixed level_dynamic_start, off[n+1] */
#define SWPM_LEVEL_RECORD_START 3    /* off[n+1] */
#define SWPM_LEVEL_COLLAPSED_INDICES 4         /* skip-strip level_collapsed_indices, idx[C] */
#define SWPM_LEVEL_DYNAMIC_INDICES 4           /* mixed level_dynamic_indices, idx[D] */
#define SWPM_LEVEL_DYNAMIC_COLLAPSED_INDICES 5 /* mixed level_dynamic_collapsed_indices, idx[D] */

/* One level: it draws LODs [first_lod, lod_end) with records [record_start, record_end). skip-strip: its
 * list is INDX[index_start, + index_count) (level_indices; drawn as strips or a list, swpm_primitive_strip),
 * its collapsed list the same range of level_collapsed_indices. mixed: its static list is INDX[index_start,
 * + index_count), its dynamic list level_dynamic_indices[dynamic_start, + dynamic_count) (and the same
 * range of level_dynamic_collapsed_indices). */
typedef struct swpm_level {
    uint64_t first_lod, lod_end, record_start, record_end;
    uint64_t index_start, index_count, dynamic_start, dynamic_count;
} swpm_level;

/* One drawn skip-strip or mixed instance (format.md 3.7, 3.8): the caller's buffer holds a copy of one
 * level's list (skip-strip) or dynamic list (mixed), which set_lod edits in place. */
typedef struct swpm_level_instance {
    uint8_t *indices;      /* the caller's buffer: elements of W bytes, little-endian, as the file */
    uint64_t lod;          /* the LOD it holds */
    uint64_t level;        /* the level whose list the buffer holds */
    uint64_t applied;      /* records [0, applied) are applied: RCNT[lod] */
    uint64_t change_pos;   /* the sum of their change counts: where record `applied`'s change offsets start */
    uint64_t count;        /* elements of the level's list (skip-strip) or dynamic list (mixed) */
    uint64_t static_live;  /* mixed: live triangles of the level's static list */
    uint64_t dynamic_live; /* mixed: live triangles of the buffer (its dynamic list) */
    uint64_t dirty_first, dirty_end; /* slots [dirty_first, dirty_end) hold every write since the last take */
} swpm_level_instance;

/* n (0 for vanilla and sliding-window); level l's fields (0 if l >= n); the level that draws LOD lod (the
 * last whose first LOD is <= lod). */
uint64_t swpm_level_count(const swpm_file *f);
int swpm_level_at(const swpm_file *f, uint64_t l, swpm_level *out);
uint64_t swpm_level_of_lod(const swpm_file *f, uint64_t lod);
/* An array of SKIP / MLVL (SWPM_LEVEL_*) as stored: *count elements of *width bytes; NULL (count 0) if the
 * file has no such array. */
const uint8_t *swpm_level_array(const swpm_file *f, int which, uint64_t *count, uint32_t *width);
/* Field `column` of record r (vanilla, skip-strip: kept, tris_removed / binned, change_count,
 * prev_change_count; mixed: kept, static_tris_removed, dynamic_tris_removed, change_count,
 * prev_change_count). swpm_collapse_records gives the table (row_bytes = 4 O, mixed 5 O). */
uint32_t swpm_collapse_field(const swpm_file *f, uint64_t r, uint32_t column);
/* The bytes an instance's buffer needs: W x the longest level list (skip-strip) or dynamic list (mixed). */
uint64_t swpm_level_instance_bytes(const swpm_file *f);
/* Set an instance at LOD 0 (level 0's list copied into buffer). Returns 0 (nothing done) if the file is not
 * of that encoding or capacity is below swpm_level_instance_bytes. */
int swpm_skip_instance_init(const swpm_file *f, swpm_level_instance *inst, void *buffer, uint64_t capacity);
int swpm_mixed_instance_init(const swpm_file *f, swpm_level_instance *inst, void *buffer, uint64_t capacity);
/* Move the instance to LOD lod (clamped to L-1), as format.md 3.7 and 3.8 say a runtime does: when lod is in
 * another level, copy that level's stored list, the uncollapsed one or the collapsed one, whichever is
 * fewer records from RCNT[lod] (Forsyth's skip strips: a level change costs a copy, not a replay); then
 * apply records up to RCNT[lod] in order (each sets its change_count slots to kept) or undo them from the last
 * (setting them back to V-1-r). Sets *vertex_count to LODS vertex_count(lod).
 * skip-strip: returns the number of indices to draw, the whole buffer (its level's list), as triangle
 * strips (swpm_primitive_strip, with primitive restart at swpm_restart_index when it gives one) or as a
 * list; collapsed slots make degenerate triangles, which draw nothing.
 * mixed: returns the number of the buffer's first indices to draw as a triangle list (the live dynamic
 * part), then INDX[*static_first, + *static_count) is drawn as a second triangle list (the live static
 * part, shared by every instance). */
uint64_t swpm_skip_set_lod(const swpm_file *f, swpm_level_instance *inst, uint64_t lod, uint32_t *vertex_count);
uint64_t swpm_mixed_set_lod(const swpm_file *f, swpm_level_instance *inst, uint64_t lod, uint64_t *static_first,
                            uint64_t *static_count, uint32_t *vertex_count);
/* As swpm_vanilla_take_dirty, for a skip-strip or mixed instance (a level change marks the copied list). */
int swpm_level_take_dirty(swpm_level_instance *inst, uint64_t *first, uint64_t *end);

#ifdef __cplusplus
}
#endif
#endif /* SWPM_READER_H */

#ifdef SWPM_READER_IMPLEMENTATION
#ifndef SWPM_READER_IMPLEMENTED
#define SWPM_READER_IMPLEMENTED

#include <string.h>

/* ---- little-endian loads (no alignment assumed) ---- */
/* (forced inline under GCC and Clang: the loads sit in every per-element loop, and -O2 leaves some calls) */
#if defined(__GNUC__)
#define SWPM__INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define SWPM__INLINE static __forceinline /* (MSVC's C mode before /std:c11 has no `inline` keyword) */
#else
#define SWPM__INLINE static inline
#endif
SWPM__INLINE uint32_t swpm__u16(const uint8_t *p) { return (uint32_t)p[0] | ((uint32_t)p[1] << 8); }
SWPM__INLINE uint32_t swpm__u32(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t swpm__u64(const uint8_t *p) { return (uint64_t)swpm__u32(p) | ((uint64_t)swpm__u32(p + 4) << 32); }
SWPM__INLINE uint32_t swpm__uw(const uint8_t *p, uint32_t w) { return w == 2 ? swpm__u16(p) : swpm__u32(p); }

/* ---- CRC-32 (ISO-HDLC / zlib: reflected 0x04C11DB7, init and final xor 0xFFFFFFFF; format.md 2.1) ---- */
/* Slicing-by-8 tables: [0] the byte-wise table, [k][i] = [k-1][i] >> 8 ^ [0][[k-1][i] & 0xFF] (eight bytes a
 * step: the CRC is most of the time swpm_open spends on a large file). */
static const uint32_t swpm__crc_table[8][256] = {
    {0x00000000u, 0x77073096u, 0xee0e612cu, 0x990951bau, 0x076dc419u, 0x706af48fu, 0xe963a535u, 0x9e6495a3u,
     0x0edb8832u, 0x79dcb8a4u, 0xe0d5e91eu, 0x97d2d988u, 0x09b64c2bu, 0x7eb17cbdu, 0xe7b82d07u, 0x90bf1d91u,
     0x1db71064u, 0x6ab020f2u, 0xf3b97148u, 0x84be41deu, 0x1adad47du, 0x6ddde4ebu, 0xf4d4b551u, 0x83d385c7u,
     0x136c9856u, 0x646ba8c0u, 0xfd62f97au, 0x8a65c9ecu, 0x14015c4fu, 0x63066cd9u, 0xfa0f3d63u, 0x8d080df5u,
     0x3b6e20c8u, 0x4c69105eu, 0xd56041e4u, 0xa2677172u, 0x3c03e4d1u, 0x4b04d447u, 0xd20d85fdu, 0xa50ab56bu,
     0x35b5a8fau, 0x42b2986cu, 0xdbbbc9d6u, 0xacbcf940u, 0x32d86ce3u, 0x45df5c75u, 0xdcd60dcfu, 0xabd13d59u,
     0x26d930acu, 0x51de003au, 0xc8d75180u, 0xbfd06116u, 0x21b4f4b5u, 0x56b3c423u, 0xcfba9599u, 0xb8bda50fu,
     0x2802b89eu, 0x5f058808u, 0xc60cd9b2u, 0xb10be924u, 0x2f6f7c87u, 0x58684c11u, 0xc1611dabu, 0xb6662d3du,
     0x76dc4190u, 0x01db7106u, 0x98d220bcu, 0xefd5102au, 0x71b18589u, 0x06b6b51fu, 0x9fbfe4a5u, 0xe8b8d433u,
     0x7807c9a2u, 0x0f00f934u, 0x9609a88eu, 0xe10e9818u, 0x7f6a0dbbu, 0x086d3d2du, 0x91646c97u, 0xe6635c01u,
     0x6b6b51f4u, 0x1c6c6162u, 0x856530d8u, 0xf262004eu, 0x6c0695edu, 0x1b01a57bu, 0x8208f4c1u, 0xf50fc457u,
     0x65b0d9c6u, 0x12b7e950u, 0x8bbeb8eau, 0xfcb9887cu, 0x62dd1ddfu, 0x15da2d49u, 0x8cd37cf3u, 0xfbd44c65u,
     0x4db26158u, 0x3ab551ceu, 0xa3bc0074u, 0xd4bb30e2u, 0x4adfa541u, 0x3dd895d7u, 0xa4d1c46du, 0xd3d6f4fbu,
     0x4369e96au, 0x346ed9fcu, 0xad678846u, 0xda60b8d0u, 0x44042d73u, 0x33031de5u, 0xaa0a4c5fu, 0xdd0d7cc9u,
     0x5005713cu, 0x270241aau, 0xbe0b1010u, 0xc90c2086u, 0x5768b525u, 0x206f85b3u, 0xb966d409u, 0xce61e49fu,
     0x5edef90eu, 0x29d9c998u, 0xb0d09822u, 0xc7d7a8b4u, 0x59b33d17u, 0x2eb40d81u, 0xb7bd5c3bu, 0xc0ba6cadu,
     0xedb88320u, 0x9abfb3b6u, 0x03b6e20cu, 0x74b1d29au, 0xead54739u, 0x9dd277afu, 0x04db2615u, 0x73dc1683u,
     0xe3630b12u, 0x94643b84u, 0x0d6d6a3eu, 0x7a6a5aa8u, 0xe40ecf0bu, 0x9309ff9du, 0x0a00ae27u, 0x7d079eb1u,
     0xf00f9344u, 0x8708a3d2u, 0x1e01f268u, 0x6906c2feu, 0xf762575du, 0x806567cbu, 0x196c3671u, 0x6e6b06e7u,
     0xfed41b76u, 0x89d32be0u, 0x10da7a5au, 0x67dd4accu, 0xf9b9df6fu, 0x8ebeeff9u, 0x17b7be43u, 0x60b08ed5u,
     0xd6d6a3e8u, 0xa1d1937eu, 0x38d8c2c4u, 0x4fdff252u, 0xd1bb67f1u, 0xa6bc5767u, 0x3fb506ddu, 0x48b2364bu,
     0xd80d2bdau, 0xaf0a1b4cu, 0x36034af6u, 0x41047a60u, 0xdf60efc3u, 0xa867df55u, 0x316e8eefu, 0x4669be79u,
     0xcb61b38cu, 0xbc66831au, 0x256fd2a0u, 0x5268e236u, 0xcc0c7795u, 0xbb0b4703u, 0x220216b9u, 0x5505262fu,
     0xc5ba3bbeu, 0xb2bd0b28u, 0x2bb45a92u, 0x5cb36a04u, 0xc2d7ffa7u, 0xb5d0cf31u, 0x2cd99e8bu, 0x5bdeae1du,
     0x9b64c2b0u, 0xec63f226u, 0x756aa39cu, 0x026d930au, 0x9c0906a9u, 0xeb0e363fu, 0x72076785u, 0x05005713u,
     0x95bf4a82u, 0xe2b87a14u, 0x7bb12baeu, 0x0cb61b38u, 0x92d28e9bu, 0xe5d5be0du, 0x7cdcefb7u, 0x0bdbdf21u,
     0x86d3d2d4u, 0xf1d4e242u, 0x68ddb3f8u, 0x1fda836eu, 0x81be16cdu, 0xf6b9265bu, 0x6fb077e1u, 0x18b74777u,
     0x88085ae6u, 0xff0f6a70u, 0x66063bcau, 0x11010b5cu, 0x8f659effu, 0xf862ae69u, 0x616bffd3u, 0x166ccf45u,
     0xa00ae278u, 0xd70dd2eeu, 0x4e048354u, 0x3903b3c2u, 0xa7672661u, 0xd06016f7u, 0x4969474du, 0x3e6e77dbu,
     0xaed16a4au, 0xd9d65adcu, 0x40df0b66u, 0x37d83bf0u, 0xa9bcae53u, 0xdebb9ec5u, 0x47b2cf7fu, 0x30b5ffe9u,
     0xbdbdf21cu, 0xcabac28au, 0x53b39330u, 0x24b4a3a6u, 0xbad03605u, 0xcdd70693u, 0x54de5729u, 0x23d967bfu,
     0xb3667a2eu, 0xc4614ab8u, 0x5d681b02u, 0x2a6f2b94u, 0xb40bbe37u, 0xc30c8ea1u, 0x5a05df1bu, 0x2d02ef8du},
    {0x00000000u, 0x191b3141u, 0x32366282u, 0x2b2d53c3u, 0x646cc504u, 0x7d77f445u, 0x565aa786u, 0x4f4196c7u,
     0xc8d98a08u, 0xd1c2bb49u, 0xfaefe88au, 0xe3f4d9cbu, 0xacb54f0cu, 0xb5ae7e4du, 0x9e832d8eu, 0x87981ccfu,
     0x4ac21251u, 0x53d92310u, 0x78f470d3u, 0x61ef4192u, 0x2eaed755u, 0x37b5e614u, 0x1c98b5d7u, 0x05838496u,
     0x821b9859u, 0x9b00a918u, 0xb02dfadbu, 0xa936cb9au, 0xe6775d5du, 0xff6c6c1cu, 0xd4413fdfu, 0xcd5a0e9eu,
     0x958424a2u, 0x8c9f15e3u, 0xa7b24620u, 0xbea97761u, 0xf1e8e1a6u, 0xe8f3d0e7u, 0xc3de8324u, 0xdac5b265u,
     0x5d5daeaau, 0x44469febu, 0x6f6bcc28u, 0x7670fd69u, 0x39316baeu, 0x202a5aefu, 0x0b07092cu, 0x121c386du,
     0xdf4636f3u, 0xc65d07b2u, 0xed705471u, 0xf46b6530u, 0xbb2af3f7u, 0xa231c2b6u, 0x891c9175u, 0x9007a034u,
     0x179fbcfbu, 0x0e848dbau, 0x25a9de79u, 0x3cb2ef38u, 0x73f379ffu, 0x6ae848beu, 0x41c51b7du, 0x58de2a3cu,
     0xf0794f05u, 0xe9627e44u, 0xc24f2d87u, 0xdb541cc6u, 0x94158a01u, 0x8d0ebb40u, 0xa623e883u, 0xbf38d9c2u,
     0x38a0c50du, 0x21bbf44cu, 0x0a96a78fu, 0x138d96ceu, 0x5ccc0009u, 0x45d73148u, 0x6efa628bu, 0x77e153cau,
     0xbabb5d54u, 0xa3a06c15u, 0x888d3fd6u, 0x91960e97u, 0xded79850u, 0xc7cca911u, 0xece1fad2u, 0xf5facb93u,
     0x7262d75cu, 0x6b79e61du, 0x4054b5deu, 0x594f849fu, 0x160e1258u, 0x0f152319u, 0x243870dau, 0x3d23419bu,
     0x65fd6ba7u, 0x7ce65ae6u, 0x57cb0925u, 0x4ed03864u, 0x0191aea3u, 0x188a9fe2u, 0x33a7cc21u, 0x2abcfd60u,
     0xad24e1afu, 0xb43fd0eeu, 0x9f12832du, 0x8609b26cu, 0xc94824abu, 0xd05315eau, 0xfb7e4629u, 0xe2657768u,
     0x2f3f79f6u, 0x362448b7u, 0x1d091b74u, 0x04122a35u, 0x4b53bcf2u, 0x52488db3u, 0x7965de70u, 0x607eef31u,
     0xe7e6f3feu, 0xfefdc2bfu, 0xd5d0917cu, 0xcccba03du, 0x838a36fau, 0x9a9107bbu, 0xb1bc5478u, 0xa8a76539u,
     0x3b83984bu, 0x2298a90au, 0x09b5fac9u, 0x10aecb88u, 0x5fef5d4fu, 0x46f46c0eu, 0x6dd93fcdu, 0x74c20e8cu,
     0xf35a1243u, 0xea412302u, 0xc16c70c1u, 0xd8774180u, 0x9736d747u, 0x8e2de606u, 0xa500b5c5u, 0xbc1b8484u,
     0x71418a1au, 0x685abb5bu, 0x4377e898u, 0x5a6cd9d9u, 0x152d4f1eu, 0x0c367e5fu, 0x271b2d9cu, 0x3e001cddu,
     0xb9980012u, 0xa0833153u, 0x8bae6290u, 0x92b553d1u, 0xddf4c516u, 0xc4eff457u, 0xefc2a794u, 0xf6d996d5u,
     0xae07bce9u, 0xb71c8da8u, 0x9c31de6bu, 0x852aef2au, 0xca6b79edu, 0xd37048acu, 0xf85d1b6fu, 0xe1462a2eu,
     0x66de36e1u, 0x7fc507a0u, 0x54e85463u, 0x4df36522u, 0x02b2f3e5u, 0x1ba9c2a4u, 0x30849167u, 0x299fa026u,
     0xe4c5aeb8u, 0xfdde9ff9u, 0xd6f3cc3au, 0xcfe8fd7bu, 0x80a96bbcu, 0x99b25afdu, 0xb29f093eu, 0xab84387fu,
     0x2c1c24b0u, 0x350715f1u, 0x1e2a4632u, 0x07317773u, 0x4870e1b4u, 0x516bd0f5u, 0x7a468336u, 0x635db277u,
     0xcbfad74eu, 0xd2e1e60fu, 0xf9ccb5ccu, 0xe0d7848du, 0xaf96124au, 0xb68d230bu, 0x9da070c8u, 0x84bb4189u,
     0x03235d46u, 0x1a386c07u, 0x31153fc4u, 0x280e0e85u, 0x674f9842u, 0x7e54a903u, 0x5579fac0u, 0x4c62cb81u,
     0x8138c51fu, 0x9823f45eu, 0xb30ea79du, 0xaa1596dcu, 0xe554001bu, 0xfc4f315au, 0xd7626299u, 0xce7953d8u,
     0x49e14f17u, 0x50fa7e56u, 0x7bd72d95u, 0x62cc1cd4u, 0x2d8d8a13u, 0x3496bb52u, 0x1fbbe891u, 0x06a0d9d0u,
     0x5e7ef3ecu, 0x4765c2adu, 0x6c48916eu, 0x7553a02fu, 0x3a1236e8u, 0x230907a9u, 0x0824546au, 0x113f652bu,
     0x96a779e4u, 0x8fbc48a5u, 0xa4911b66u, 0xbd8a2a27u, 0xf2cbbce0u, 0xebd08da1u, 0xc0fdde62u, 0xd9e6ef23u,
     0x14bce1bdu, 0x0da7d0fcu, 0x268a833fu, 0x3f91b27eu, 0x70d024b9u, 0x69cb15f8u, 0x42e6463bu, 0x5bfd777au,
     0xdc656bb5u, 0xc57e5af4u, 0xee530937u, 0xf7483876u, 0xb809aeb1u, 0xa1129ff0u, 0x8a3fcc33u, 0x9324fd72u},
    {0x00000000u, 0x01c26a37u, 0x0384d46eu, 0x0246be59u, 0x0709a8dcu, 0x06cbc2ebu, 0x048d7cb2u, 0x054f1685u,
     0x0e1351b8u, 0x0fd13b8fu, 0x0d9785d6u, 0x0c55efe1u, 0x091af964u, 0x08d89353u, 0x0a9e2d0au, 0x0b5c473du,
     0x1c26a370u, 0x1de4c947u, 0x1fa2771eu, 0x1e601d29u, 0x1b2f0bacu, 0x1aed619bu, 0x18abdfc2u, 0x1969b5f5u,
     0x1235f2c8u, 0x13f798ffu, 0x11b126a6u, 0x10734c91u, 0x153c5a14u, 0x14fe3023u, 0x16b88e7au, 0x177ae44du,
     0x384d46e0u, 0x398f2cd7u, 0x3bc9928eu, 0x3a0bf8b9u, 0x3f44ee3cu, 0x3e86840bu, 0x3cc03a52u, 0x3d025065u,
     0x365e1758u, 0x379c7d6fu, 0x35dac336u, 0x3418a901u, 0x3157bf84u, 0x3095d5b3u, 0x32d36beau, 0x331101ddu,
     0x246be590u, 0x25a98fa7u, 0x27ef31feu, 0x262d5bc9u, 0x23624d4cu, 0x22a0277bu, 0x20e69922u, 0x2124f315u,
     0x2a78b428u, 0x2bbade1fu, 0x29fc6046u, 0x283e0a71u, 0x2d711cf4u, 0x2cb376c3u, 0x2ef5c89au, 0x2f37a2adu,
     0x709a8dc0u, 0x7158e7f7u, 0x731e59aeu, 0x72dc3399u, 0x7793251cu, 0x76514f2bu, 0x7417f172u, 0x75d59b45u,
     0x7e89dc78u, 0x7f4bb64fu, 0x7d0d0816u, 0x7ccf6221u, 0x798074a4u, 0x78421e93u, 0x7a04a0cau, 0x7bc6cafdu,
     0x6cbc2eb0u, 0x6d7e4487u, 0x6f38fadeu, 0x6efa90e9u, 0x6bb5866cu, 0x6a77ec5bu, 0x68315202u, 0x69f33835u,
     0x62af7f08u, 0x636d153fu, 0x612bab66u, 0x60e9c151u, 0x65a6d7d4u, 0x6464bde3u, 0x662203bau, 0x67e0698du,
     0x48d7cb20u, 0x4915a117u, 0x4b531f4eu, 0x4a917579u, 0x4fde63fcu, 0x4e1c09cbu, 0x4c5ab792u, 0x4d98dda5u,
     0x46c49a98u, 0x4706f0afu, 0x45404ef6u, 0x448224c1u, 0x41cd3244u, 0x400f5873u, 0x4249e62au, 0x438b8c1du,
     0x54f16850u, 0x55330267u, 0x5775bc3eu, 0x56b7d609u, 0x53f8c08cu, 0x523aaabbu, 0x507c14e2u, 0x51be7ed5u,
     0x5ae239e8u, 0x5b2053dfu, 0x5966ed86u, 0x58a487b1u, 0x5deb9134u, 0x5c29fb03u, 0x5e6f455au, 0x5fad2f6du,
     0xe1351b80u, 0xe0f771b7u, 0xe2b1cfeeu, 0xe373a5d9u, 0xe63cb35cu, 0xe7fed96bu, 0xe5b86732u, 0xe47a0d05u,
     0xef264a38u, 0xeee4200fu, 0xeca29e56u, 0xed60f461u, 0xe82fe2e4u, 0xe9ed88d3u, 0xebab368au, 0xea695cbdu,
     0xfd13b8f0u, 0xfcd1d2c7u, 0xfe976c9eu, 0xff5506a9u, 0xfa1a102cu, 0xfbd87a1bu, 0xf99ec442u, 0xf85cae75u,
     0xf300e948u, 0xf2c2837fu, 0xf0843d26u, 0xf1465711u, 0xf4094194u, 0xf5cb2ba3u, 0xf78d95fau, 0xf64fffcdu,
     0xd9785d60u, 0xd8ba3757u, 0xdafc890eu, 0xdb3ee339u, 0xde71f5bcu, 0xdfb39f8bu, 0xddf521d2u, 0xdc374be5u,
     0xd76b0cd8u, 0xd6a966efu, 0xd4efd8b6u, 0xd52db281u, 0xd062a404u, 0xd1a0ce33u, 0xd3e6706au, 0xd2241a5du,
     0xc55efe10u, 0xc49c9427u, 0xc6da2a7eu, 0xc7184049u, 0xc25756ccu, 0xc3953cfbu, 0xc1d382a2u, 0xc011e895u,
     0xcb4dafa8u, 0xca8fc59fu, 0xc8c97bc6u, 0xc90b11f1u, 0xcc440774u, 0xcd866d43u, 0xcfc0d31au, 0xce02b92du,
     0x91af9640u, 0x906dfc77u, 0x922b422eu, 0x93e92819u, 0x96a63e9cu, 0x976454abu, 0x9522eaf2u, 0x94e080c5u,
     0x9fbcc7f8u, 0x9e7eadcfu, 0x9c381396u, 0x9dfa79a1u, 0x98b56f24u, 0x99770513u, 0x9b31bb4au, 0x9af3d17du,
     0x8d893530u, 0x8c4b5f07u, 0x8e0de15eu, 0x8fcf8b69u, 0x8a809decu, 0x8b42f7dbu, 0x89044982u, 0x88c623b5u,
     0x839a6488u, 0x82580ebfu, 0x801eb0e6u, 0x81dcdad1u, 0x8493cc54u, 0x8551a663u, 0x8717183au, 0x86d5720du,
     0xa9e2d0a0u, 0xa820ba97u, 0xaa6604ceu, 0xaba46ef9u, 0xaeeb787cu, 0xaf29124bu, 0xad6fac12u, 0xacadc625u,
     0xa7f18118u, 0xa633eb2fu, 0xa4755576u, 0xa5b73f41u, 0xa0f829c4u, 0xa13a43f3u, 0xa37cfdaau, 0xa2be979du,
     0xb5c473d0u, 0xb40619e7u, 0xb640a7beu, 0xb782cd89u, 0xb2cddb0cu, 0xb30fb13bu, 0xb1490f62u, 0xb08b6555u,
     0xbbd72268u, 0xba15485fu, 0xb853f606u, 0xb9919c31u, 0xbcde8ab4u, 0xbd1ce083u, 0xbf5a5edau, 0xbe9834edu},
    {0x00000000u, 0xb8bc6765u, 0xaa09c88bu, 0x12b5afeeu, 0x8f629757u, 0x37def032u, 0x256b5fdcu, 0x9dd738b9u,
     0xc5b428efu, 0x7d084f8au, 0x6fbde064u, 0xd7018701u, 0x4ad6bfb8u, 0xf26ad8ddu, 0xe0df7733u, 0x58631056u,
     0x5019579fu, 0xe8a530fau, 0xfa109f14u, 0x42acf871u, 0xdf7bc0c8u, 0x67c7a7adu, 0x75720843u, 0xcdce6f26u,
     0x95ad7f70u, 0x2d111815u, 0x3fa4b7fbu, 0x8718d09eu, 0x1acfe827u, 0xa2738f42u, 0xb0c620acu, 0x087a47c9u,
     0xa032af3eu, 0x188ec85bu, 0x0a3b67b5u, 0xb28700d0u, 0x2f503869u, 0x97ec5f0cu, 0x8559f0e2u, 0x3de59787u,
     0x658687d1u, 0xdd3ae0b4u, 0xcf8f4f5au, 0x7733283fu, 0xeae41086u, 0x525877e3u, 0x40edd80du, 0xf851bf68u,
     0xf02bf8a1u, 0x48979fc4u, 0x5a22302au, 0xe29e574fu, 0x7f496ff6u, 0xc7f50893u, 0xd540a77du, 0x6dfcc018u,
     0x359fd04eu, 0x8d23b72bu, 0x9f9618c5u, 0x272a7fa0u, 0xbafd4719u, 0x0241207cu, 0x10f48f92u, 0xa848e8f7u,
     0x9b14583du, 0x23a83f58u, 0x311d90b6u, 0x89a1f7d3u, 0x1476cf6au, 0xaccaa80fu, 0xbe7f07e1u, 0x06c36084u,
     0x5ea070d2u, 0xe61c17b7u, 0xf4a9b859u, 0x4c15df3cu, 0xd1c2e785u, 0x697e80e0u, 0x7bcb2f0eu, 0xc377486bu,
     0xcb0d0fa2u, 0x73b168c7u, 0x6104c729u, 0xd9b8a04cu, 0x446f98f5u, 0xfcd3ff90u, 0xee66507eu, 0x56da371bu,
     0x0eb9274du, 0xb6054028u, 0xa4b0efc6u, 0x1c0c88a3u, 0x81dbb01au, 0x3967d77fu, 0x2bd27891u, 0x936e1ff4u,
     0x3b26f703u, 0x839a9066u, 0x912f3f88u, 0x299358edu, 0xb4446054u, 0x0cf80731u, 0x1e4da8dfu, 0xa6f1cfbau,
     0xfe92dfecu, 0x462eb889u, 0x549b1767u, 0xec277002u, 0x71f048bbu, 0xc94c2fdeu, 0xdbf98030u, 0x6345e755u,
     0x6b3fa09cu, 0xd383c7f9u, 0xc1366817u, 0x798a0f72u, 0xe45d37cbu, 0x5ce150aeu, 0x4e54ff40u, 0xf6e89825u,
     0xae8b8873u, 0x1637ef16u, 0x048240f8u, 0xbc3e279du, 0x21e91f24u, 0x99557841u, 0x8be0d7afu, 0x335cb0cau,
     0xed59b63bu, 0x55e5d15eu, 0x47507eb0u, 0xffec19d5u, 0x623b216cu, 0xda874609u, 0xc832e9e7u, 0x708e8e82u,
     0x28ed9ed4u, 0x9051f9b1u, 0x82e4565fu, 0x3a58313au, 0xa78f0983u, 0x1f336ee6u, 0x0d86c108u, 0xb53aa66du,
     0xbd40e1a4u, 0x05fc86c1u, 0x1749292fu, 0xaff54e4au, 0x322276f3u, 0x8a9e1196u, 0x982bbe78u, 0x2097d91du,
     0x78f4c94bu, 0xc048ae2eu, 0xd2fd01c0u, 0x6a4166a5u, 0xf7965e1cu, 0x4f2a3979u, 0x5d9f9697u, 0xe523f1f2u,
     0x4d6b1905u, 0xf5d77e60u, 0xe762d18eu, 0x5fdeb6ebu, 0xc2098e52u, 0x7ab5e937u, 0x680046d9u, 0xd0bc21bcu,
     0x88df31eau, 0x3063568fu, 0x22d6f961u, 0x9a6a9e04u, 0x07bda6bdu, 0xbf01c1d8u, 0xadb46e36u, 0x15080953u,
     0x1d724e9au, 0xa5ce29ffu, 0xb77b8611u, 0x0fc7e174u, 0x9210d9cdu, 0x2aacbea8u, 0x38191146u, 0x80a57623u,
     0xd8c66675u, 0x607a0110u, 0x72cfaefeu, 0xca73c99bu, 0x57a4f122u, 0xef189647u, 0xfdad39a9u, 0x45115eccu,
     0x764dee06u, 0xcef18963u, 0xdc44268du, 0x64f841e8u, 0xf92f7951u, 0x41931e34u, 0x5326b1dau, 0xeb9ad6bfu,
     0xb3f9c6e9u, 0x0b45a18cu, 0x19f00e62u, 0xa14c6907u, 0x3c9b51beu, 0x842736dbu, 0x96929935u, 0x2e2efe50u,
     0x2654b999u, 0x9ee8defcu, 0x8c5d7112u, 0x34e11677u, 0xa9362eceu, 0x118a49abu, 0x033fe645u, 0xbb838120u,
     0xe3e09176u, 0x5b5cf613u, 0x49e959fdu, 0xf1553e98u, 0x6c820621u, 0xd43e6144u, 0xc68bceaau, 0x7e37a9cfu,
     0xd67f4138u, 0x6ec3265du, 0x7c7689b3u, 0xc4caeed6u, 0x591dd66fu, 0xe1a1b10au, 0xf3141ee4u, 0x4ba87981u,
     0x13cb69d7u, 0xab770eb2u, 0xb9c2a15cu, 0x017ec639u, 0x9ca9fe80u, 0x241599e5u, 0x36a0360bu, 0x8e1c516eu,
     0x866616a7u, 0x3eda71c2u, 0x2c6fde2cu, 0x94d3b949u, 0x090481f0u, 0xb1b8e695u, 0xa30d497bu, 0x1bb12e1eu,
     0x43d23e48u, 0xfb6e592du, 0xe9dbf6c3u, 0x516791a6u, 0xccb0a91fu, 0x740cce7au, 0x66b96194u, 0xde0506f1u},
    {0x00000000u, 0x3d6029b0u, 0x7ac05360u, 0x47a07ad0u, 0xf580a6c0u, 0xc8e08f70u, 0x8f40f5a0u, 0xb220dc10u,
     0x30704bc1u, 0x0d106271u, 0x4ab018a1u, 0x77d03111u, 0xc5f0ed01u, 0xf890c4b1u, 0xbf30be61u, 0x825097d1u,
     0x60e09782u, 0x5d80be32u, 0x1a20c4e2u, 0x2740ed52u, 0x95603142u, 0xa80018f2u, 0xefa06222u, 0xd2c04b92u,
     0x5090dc43u, 0x6df0f5f3u, 0x2a508f23u, 0x1730a693u, 0xa5107a83u, 0x98705333u, 0xdfd029e3u, 0xe2b00053u,
     0xc1c12f04u, 0xfca106b4u, 0xbb017c64u, 0x866155d4u, 0x344189c4u, 0x0921a074u, 0x4e81daa4u, 0x73e1f314u,
     0xf1b164c5u, 0xccd14d75u, 0x8b7137a5u, 0xb6111e15u, 0x0431c205u, 0x3951ebb5u, 0x7ef19165u, 0x4391b8d5u,
     0xa121b886u, 0x9c419136u, 0xdbe1ebe6u, 0xe681c256u, 0x54a11e46u, 0x69c137f6u, 0x2e614d26u, 0x13016496u,
     0x9151f347u, 0xac31daf7u, 0xeb91a027u, 0xd6f18997u, 0x64d15587u, 0x59b17c37u, 0x1e1106e7u, 0x23712f57u,
     0x58f35849u, 0x659371f9u, 0x22330b29u, 0x1f532299u, 0xad73fe89u, 0x9013d739u, 0xd7b3ade9u, 0xead38459u,
     0x68831388u, 0x55e33a38u, 0x124340e8u, 0x2f236958u, 0x9d03b548u, 0xa0639cf8u, 0xe7c3e628u, 0xdaa3cf98u,
     0x3813cfcbu, 0x0573e67bu, 0x42d39cabu, 0x7fb3b51bu, 0xcd93690bu, 0xf0f340bbu, 0xb7533a6bu, 0x8a3313dbu,
     0x0863840au, 0x3503adbau, 0x72a3d76au, 0x4fc3fedau, 0xfde322cau, 0xc0830b7au, 0x872371aau, 0xba43581au,
     0x9932774du, 0xa4525efdu, 0xe3f2242du, 0xde920d9du, 0x6cb2d18du, 0x51d2f83du, 0x167282edu, 0x2b12ab5du,
     0xa9423c8cu, 0x9422153cu, 0xd3826fecu, 0xeee2465cu, 0x5cc29a4cu, 0x61a2b3fcu, 0x2602c92cu, 0x1b62e09cu,
     0xf9d2e0cfu, 0xc4b2c97fu, 0x8312b3afu, 0xbe729a1fu, 0x0c52460fu, 0x31326fbfu, 0x7692156fu, 0x4bf23cdfu,
     0xc9a2ab0eu, 0xf4c282beu, 0xb362f86eu, 0x8e02d1deu, 0x3c220dceu, 0x0142247eu, 0x46e25eaeu, 0x7b82771eu,
     0xb1e6b092u, 0x8c869922u, 0xcb26e3f2u, 0xf646ca42u, 0x44661652u, 0x79063fe2u, 0x3ea64532u, 0x03c66c82u,
     0x8196fb53u, 0xbcf6d2e3u, 0xfb56a833u, 0xc6368183u, 0x74165d93u, 0x49767423u, 0x0ed60ef3u, 0x33b62743u,
     0xd1062710u, 0xec660ea0u, 0xabc67470u, 0x96a65dc0u, 0x248681d0u, 0x19e6a860u, 0x5e46d2b0u, 0x6326fb00u,
     0xe1766cd1u, 0xdc164561u, 0x9bb63fb1u, 0xa6d61601u, 0x14f6ca11u, 0x2996e3a1u, 0x6e369971u, 0x5356b0c1u,
     0x70279f96u, 0x4d47b626u, 0x0ae7ccf6u, 0x3787e546u, 0x85a73956u, 0xb8c710e6u, 0xff676a36u, 0xc2074386u,
     0x4057d457u, 0x7d37fde7u, 0x3a978737u, 0x07f7ae87u, 0xb5d77297u, 0x88b75b27u, 0xcf1721f7u, 0xf2770847u,
     0x10c70814u, 0x2da721a4u, 0x6a075b74u, 0x576772c4u, 0xe547aed4u, 0xd8278764u, 0x9f87fdb4u, 0xa2e7d404u,
     0x20b743d5u, 0x1dd76a65u, 0x5a7710b5u, 0x67173905u, 0xd537e515u, 0xe857cca5u, 0xaff7b675u, 0x92979fc5u,
     0xe915e8dbu, 0xd475c16bu, 0x93d5bbbbu, 0xaeb5920bu, 0x1c954e1bu, 0x21f567abu, 0x66551d7bu, 0x5b3534cbu,
     0xd965a31au, 0xe4058aaau, 0xa3a5f07au, 0x9ec5d9cau, 0x2ce505dau, 0x11852c6au, 0x562556bau, 0x6b457f0au,
     0x89f57f59u, 0xb49556e9u, 0xf3352c39u, 0xce550589u, 0x7c75d999u, 0x4115f029u, 0x06b58af9u, 0x3bd5a349u,
     0xb9853498u, 0x84e51d28u, 0xc34567f8u, 0xfe254e48u, 0x4c059258u, 0x7165bbe8u, 0x36c5c138u, 0x0ba5e888u,
     0x28d4c7dfu, 0x15b4ee6fu, 0x521494bfu, 0x6f74bd0fu, 0xdd54611fu, 0xe03448afu, 0xa794327fu, 0x9af41bcfu,
     0x18a48c1eu, 0x25c4a5aeu, 0x6264df7eu, 0x5f04f6ceu, 0xed242adeu, 0xd044036eu, 0x97e479beu, 0xaa84500eu,
     0x4834505du, 0x755479edu, 0x32f4033du, 0x0f942a8du, 0xbdb4f69du, 0x80d4df2du, 0xc774a5fdu, 0xfa148c4du,
     0x78441b9cu, 0x4524322cu, 0x028448fcu, 0x3fe4614cu, 0x8dc4bd5cu, 0xb0a494ecu, 0xf704ee3cu, 0xca64c78cu},
    {0x00000000u, 0xcb5cd3a5u, 0x4dc8a10bu, 0x869472aeu, 0x9b914216u, 0x50cd91b3u, 0xd659e31du, 0x1d0530b8u,
     0xec53826du, 0x270f51c8u, 0xa19b2366u, 0x6ac7f0c3u, 0x77c2c07bu, 0xbc9e13deu, 0x3a0a6170u, 0xf156b2d5u,
     0x03d6029bu, 0xc88ad13eu, 0x4e1ea390u, 0x85427035u, 0x9847408du, 0x531b9328u, 0xd58fe186u, 0x1ed33223u,
     0xef8580f6u, 0x24d95353u, 0xa24d21fdu, 0x6911f258u, 0x7414c2e0u, 0xbf481145u, 0x39dc63ebu, 0xf280b04eu,
     0x07ac0536u, 0xccf0d693u, 0x4a64a43du, 0x81387798u, 0x9c3d4720u, 0x57619485u, 0xd1f5e62bu, 0x1aa9358eu,
     0xebff875bu, 0x20a354feu, 0xa6372650u, 0x6d6bf5f5u, 0x706ec54du, 0xbb3216e8u, 0x3da66446u, 0xf6fab7e3u,
     0x047a07adu, 0xcf26d408u, 0x49b2a6a6u, 0x82ee7503u, 0x9feb45bbu, 0x54b7961eu, 0xd223e4b0u, 0x197f3715u,
     0xe82985c0u, 0x23755665u, 0xa5e124cbu, 0x6ebdf76eu, 0x73b8c7d6u, 0xb8e41473u, 0x3e7066ddu, 0xf52cb578u,
     0x0f580a6cu, 0xc404d9c9u, 0x4290ab67u, 0x89cc78c2u, 0x94c9487au, 0x5f959bdfu, 0xd901e971u, 0x125d3ad4u,
     0xe30b8801u, 0x28575ba4u, 0xaec3290au, 0x659ffaafu, 0x789aca17u, 0xb3c619b2u, 0x35526b1cu, 0xfe0eb8b9u,
     0x0c8e08f7u, 0xc7d2db52u, 0x4146a9fcu, 0x8a1a7a59u, 0x971f4ae1u, 0x5c439944u, 0xdad7ebeau, 0x118b384fu,
     0xe0dd8a9au, 0x2b81593fu, 0xad152b91u, 0x6649f834u, 0x7b4cc88cu, 0xb0101b29u, 0x36846987u, 0xfdd8ba22u,
     0x08f40f5au, 0xc3a8dcffu, 0x453cae51u, 0x8e607df4u, 0x93654d4cu, 0x58399ee9u, 0xdeadec47u, 0x15f13fe2u,
     0xe4a78d37u, 0x2ffb5e92u, 0xa96f2c3cu, 0x6233ff99u, 0x7f36cf21u, 0xb46a1c84u, 0x32fe6e2au, 0xf9a2bd8fu,
     0x0b220dc1u, 0xc07ede64u, 0x46eaaccau, 0x8db67f6fu, 0x90b34fd7u, 0x5bef9c72u, 0xdd7beedcu, 0x16273d79u,
     0xe7718facu, 0x2c2d5c09u, 0xaab92ea7u, 0x61e5fd02u, 0x7ce0cdbau, 0xb7bc1e1fu, 0x31286cb1u, 0xfa74bf14u,
     0x1eb014d8u, 0xd5ecc77du, 0x5378b5d3u, 0x98246676u, 0x852156ceu, 0x4e7d856bu, 0xc8e9f7c5u, 0x03b52460u,
     0xf2e396b5u, 0x39bf4510u, 0xbf2b37beu, 0x7477e41bu, 0x6972d4a3u, 0xa22e0706u, 0x24ba75a8u, 0xefe6a60du,
     0x1d661643u, 0xd63ac5e6u, 0x50aeb748u, 0x9bf264edu, 0x86f75455u, 0x4dab87f0u, 0xcb3ff55eu, 0x006326fbu,
     0xf135942eu, 0x3a69478bu, 0xbcfd3525u, 0x77a1e680u, 0x6aa4d638u, 0xa1f8059du, 0x276c7733u, 0xec30a496u,
     0x191c11eeu, 0xd240c24bu, 0x54d4b0e5u, 0x9f886340u, 0x828d53f8u, 0x49d1805du, 0xcf45f2f3u, 0x04192156u,
     0xf54f9383u, 0x3e134026u, 0xb8873288u, 0x73dbe12du, 0x6eded195u, 0xa5820230u, 0x2316709eu, 0xe84aa33bu,
     0x1aca1375u, 0xd196c0d0u, 0x5702b27eu, 0x9c5e61dbu, 0x815b5163u, 0x4a0782c6u, 0xcc93f068u, 0x07cf23cdu,
     0xf6999118u, 0x3dc542bdu, 0xbb513013u, 0x700de3b6u, 0x6d08d30eu, 0xa65400abu, 0x20c07205u, 0xeb9ca1a0u,
     0x11e81eb4u, 0xdab4cd11u, 0x5c20bfbfu, 0x977c6c1au, 0x8a795ca2u, 0x41258f07u, 0xc7b1fda9u, 0x0ced2e0cu,
     0xfdbb9cd9u, 0x36e74f7cu, 0xb0733dd2u, 0x7b2fee77u, 0x662adecfu, 0xad760d6au, 0x2be27fc4u, 0xe0beac61u,
     0x123e1c2fu, 0xd962cf8au, 0x5ff6bd24u, 0x94aa6e81u, 0x89af5e39u, 0x42f38d9cu, 0xc467ff32u, 0x0f3b2c97u,
     0xfe6d9e42u, 0x35314de7u, 0xb3a53f49u, 0x78f9ececu, 0x65fcdc54u, 0xaea00ff1u, 0x28347d5fu, 0xe368aefau,
     0x16441b82u, 0xdd18c827u, 0x5b8cba89u, 0x90d0692cu, 0x8dd55994u, 0x46898a31u, 0xc01df89fu, 0x0b412b3au,
     0xfa1799efu, 0x314b4a4au, 0xb7df38e4u, 0x7c83eb41u, 0x6186dbf9u, 0xaada085cu, 0x2c4e7af2u, 0xe712a957u,
     0x15921919u, 0xdececabcu, 0x585ab812u, 0x93066bb7u, 0x8e035b0fu, 0x455f88aau, 0xc3cbfa04u, 0x089729a1u,
     0xf9c19b74u, 0x329d48d1u, 0xb4093a7fu, 0x7f55e9dau, 0x6250d962u, 0xa90c0ac7u, 0x2f987869u, 0xe4c4abccu},
    {0x00000000u, 0xa6770bb4u, 0x979f1129u, 0x31e81a9du, 0xf44f2413u, 0x52382fa7u, 0x63d0353au, 0xc5a73e8eu,
     0x33ef4e67u, 0x959845d3u, 0xa4705f4eu, 0x020754fau, 0xc7a06a74u, 0x61d761c0u, 0x503f7b5du, 0xf64870e9u,
     0x67de9cceu, 0xc1a9977au, 0xf0418de7u, 0x56368653u, 0x9391b8ddu, 0x35e6b369u, 0x040ea9f4u, 0xa279a240u,
     0x5431d2a9u, 0xf246d91du, 0xc3aec380u, 0x65d9c834u, 0xa07ef6bau, 0x0609fd0eu, 0x37e1e793u, 0x9196ec27u,
     0xcfbd399cu, 0x69ca3228u, 0x582228b5u, 0xfe552301u, 0x3bf21d8fu, 0x9d85163bu, 0xac6d0ca6u, 0x0a1a0712u,
     0xfc5277fbu, 0x5a257c4fu, 0x6bcd66d2u, 0xcdba6d66u, 0x081d53e8u, 0xae6a585cu, 0x9f8242c1u, 0x39f54975u,
     0xa863a552u, 0x0e14aee6u, 0x3ffcb47bu, 0x998bbfcfu, 0x5c2c8141u, 0xfa5b8af5u, 0xcbb39068u, 0x6dc49bdcu,
     0x9b8ceb35u, 0x3dfbe081u, 0x0c13fa1cu, 0xaa64f1a8u, 0x6fc3cf26u, 0xc9b4c492u, 0xf85cde0fu, 0x5e2bd5bbu,
     0x440b7579u, 0xe27c7ecdu, 0xd3946450u, 0x75e36fe4u, 0xb044516au, 0x16335adeu, 0x27db4043u, 0x81ac4bf7u,
     0x77e43b1eu, 0xd19330aau, 0xe07b2a37u, 0x460c2183u, 0x83ab1f0du, 0x25dc14b9u, 0x14340e24u, 0xb2430590u,
     0x23d5e9b7u, 0x85a2e203u, 0xb44af89eu, 0x123df32au, 0xd79acda4u, 0x71edc610u, 0x4005dc8du, 0xe672d739u,
     0x103aa7d0u, 0xb64dac64u, 0x87a5b6f9u, 0x21d2bd4du, 0xe47583c3u, 0x42028877u, 0x73ea92eau, 0xd59d995eu,
     0x8bb64ce5u, 0x2dc14751u, 0x1c295dccu, 0xba5e5678u, 0x7ff968f6u, 0xd98e6342u, 0xe86679dfu, 0x4e11726bu,
     0xb8590282u, 0x1e2e0936u, 0x2fc613abu, 0x89b1181fu, 0x4c162691u, 0xea612d25u, 0xdb8937b8u, 0x7dfe3c0cu,
     0xec68d02bu, 0x4a1fdb9fu, 0x7bf7c102u, 0xdd80cab6u, 0x1827f438u, 0xbe50ff8cu, 0x8fb8e511u, 0x29cfeea5u,
     0xdf879e4cu, 0x79f095f8u, 0x48188f65u, 0xee6f84d1u, 0x2bc8ba5fu, 0x8dbfb1ebu, 0xbc57ab76u, 0x1a20a0c2u,
     0x8816eaf2u, 0x2e61e146u, 0x1f89fbdbu, 0xb9fef06fu, 0x7c59cee1u, 0xda2ec555u, 0xebc6dfc8u, 0x4db1d47cu,
     0xbbf9a495u, 0x1d8eaf21u, 0x2c66b5bcu, 0x8a11be08u, 0x4fb68086u, 0xe9c18b32u, 0xd82991afu, 0x7e5e9a1bu,
     0xefc8763cu, 0x49bf7d88u, 0x78576715u, 0xde206ca1u, 0x1b87522fu, 0xbdf0599bu, 0x8c184306u, 0x2a6f48b2u,
     0xdc27385bu, 0x7a5033efu, 0x4bb82972u, 0xedcf22c6u, 0x28681c48u, 0x8e1f17fcu, 0xbff70d61u, 0x198006d5u,
     0x47abd36eu, 0xe1dcd8dau, 0xd034c247u, 0x7643c9f3u, 0xb3e4f77du, 0x1593fcc9u, 0x247be654u, 0x820cede0u,
     0x74449d09u, 0xd23396bdu, 0xe3db8c20u, 0x45ac8794u, 0x800bb91au, 0x267cb2aeu, 0x1794a833u, 0xb1e3a387u,
     0x20754fa0u, 0x86024414u, 0xb7ea5e89u, 0x119d553du, 0xd43a6bb3u, 0x724d6007u, 0x43a57a9au, 0xe5d2712eu,
     0x139a01c7u, 0xb5ed0a73u, 0x840510eeu, 0x22721b5au, 0xe7d525d4u, 0x41a22e60u, 0x704a34fdu, 0xd63d3f49u,
     0xcc1d9f8bu, 0x6a6a943fu, 0x5b828ea2u, 0xfdf58516u, 0x3852bb98u, 0x9e25b02cu, 0xafcdaab1u, 0x09baa105u,
     0xfff2d1ecu, 0x5985da58u, 0x686dc0c5u, 0xce1acb71u, 0x0bbdf5ffu, 0xadcafe4bu, 0x9c22e4d6u, 0x3a55ef62u,
     0xabc30345u, 0x0db408f1u, 0x3c5c126cu, 0x9a2b19d8u, 0x5f8c2756u, 0xf9fb2ce2u, 0xc813367fu, 0x6e643dcbu,
     0x982c4d22u, 0x3e5b4696u, 0x0fb35c0bu, 0xa9c457bfu, 0x6c636931u, 0xca146285u, 0xfbfc7818u, 0x5d8b73acu,
     0x03a0a617u, 0xa5d7ada3u, 0x943fb73eu, 0x3248bc8au, 0xf7ef8204u, 0x519889b0u, 0x6070932du, 0xc6079899u,
     0x304fe870u, 0x9638e3c4u, 0xa7d0f959u, 0x01a7f2edu, 0xc400cc63u, 0x6277c7d7u, 0x539fdd4au, 0xf5e8d6feu,
     0x647e3ad9u, 0xc209316du, 0xf3e12bf0u, 0x55962044u, 0x90311ecau, 0x3646157eu, 0x07ae0fe3u, 0xa1d90457u,
     0x579174beu, 0xf1e67f0au, 0xc00e6597u, 0x66796e23u, 0xa3de50adu, 0x05a95b19u, 0x34414184u, 0x92364a30u},
    {0x00000000u, 0xccaa009eu, 0x4225077du, 0x8e8f07e3u, 0x844a0efau, 0x48e00e64u, 0xc66f0987u, 0x0ac50919u,
     0xd3e51bb5u, 0x1f4f1b2bu, 0x91c01cc8u, 0x5d6a1c56u, 0x57af154fu, 0x9b0515d1u, 0x158a1232u, 0xd92012acu,
     0x7cbb312bu, 0xb01131b5u, 0x3e9e3656u, 0xf23436c8u, 0xf8f13fd1u, 0x345b3f4fu, 0xbad438acu, 0x767e3832u,
     0xaf5e2a9eu, 0x63f42a00u, 0xed7b2de3u, 0x21d12d7du, 0x2b142464u, 0xe7be24fau, 0x69312319u, 0xa59b2387u,
     0xf9766256u, 0x35dc62c8u, 0xbb53652bu, 0x77f965b5u, 0x7d3c6cacu, 0xb1966c32u, 0x3f196bd1u, 0xf3b36b4fu,
     0x2a9379e3u, 0xe639797du, 0x68b67e9eu, 0xa41c7e00u, 0xaed97719u, 0x62737787u, 0xecfc7064u, 0x205670fau,
     0x85cd537du, 0x496753e3u, 0xc7e85400u, 0x0b42549eu, 0x01875d87u, 0xcd2d5d19u, 0x43a25afau, 0x8f085a64u,
     0x562848c8u, 0x9a824856u, 0x140d4fb5u, 0xd8a74f2bu, 0xd2624632u, 0x1ec846acu, 0x9047414fu, 0x5ced41d1u,
     0x299dc2edu, 0xe537c273u, 0x6bb8c590u, 0xa712c50eu, 0xadd7cc17u, 0x617dcc89u, 0xeff2cb6au, 0x2358cbf4u,
     0xfa78d958u, 0x36d2d9c6u, 0xb85dde25u, 0x74f7debbu, 0x7e32d7a2u, 0xb298d73cu, 0x3c17d0dfu, 0xf0bdd041u,
     0x5526f3c6u, 0x998cf358u, 0x1703f4bbu, 0xdba9f425u, 0xd16cfd3cu, 0x1dc6fda2u, 0x9349fa41u, 0x5fe3fadfu,
     0x86c3e873u, 0x4a69e8edu, 0xc4e6ef0eu, 0x084cef90u, 0x0289e689u, 0xce23e617u, 0x40ace1f4u, 0x8c06e16au,
     0xd0eba0bbu, 0x1c41a025u, 0x92cea7c6u, 0x5e64a758u, 0x54a1ae41u, 0x980baedfu, 0x1684a93cu, 0xda2ea9a2u,
     0x030ebb0eu, 0xcfa4bb90u, 0x412bbc73u, 0x8d81bcedu, 0x8744b5f4u, 0x4beeb56au, 0xc561b289u, 0x09cbb217u,
     0xac509190u, 0x60fa910eu, 0xee7596edu, 0x22df9673u, 0x281a9f6au, 0xe4b09ff4u, 0x6a3f9817u, 0xa6959889u,
     0x7fb58a25u, 0xb31f8abbu, 0x3d908d58u, 0xf13a8dc6u, 0xfbff84dfu, 0x37558441u, 0xb9da83a2u, 0x7570833cu,
     0x533b85dau, 0x9f918544u, 0x111e82a7u, 0xddb48239u, 0xd7718b20u, 0x1bdb8bbeu, 0x95548c5du, 0x59fe8cc3u,
     0x80de9e6fu, 0x4c749ef1u, 0xc2fb9912u, 0x0e51998cu, 0x04949095u, 0xc83e900bu, 0x46b197e8u, 0x8a1b9776u,
     0x2f80b4f1u, 0xe32ab46fu, 0x6da5b38cu, 0xa10fb312u, 0xabcaba0bu, 0x6760ba95u, 0xe9efbd76u, 0x2545bde8u,
     0xfc65af44u, 0x30cfafdau, 0xbe40a839u, 0x72eaa8a7u, 0x782fa1beu, 0xb485a120u, 0x3a0aa6c3u, 0xf6a0a65du,
     0xaa4de78cu, 0x66e7e712u, 0xe868e0f1u, 0x24c2e06fu, 0x2e07e976u, 0xe2ade9e8u, 0x6c22ee0bu, 0xa088ee95u,
     0x79a8fc39u, 0xb502fca7u, 0x3b8dfb44u, 0xf727fbdau, 0xfde2f2c3u, 0x3148f25du, 0xbfc7f5beu, 0x736df520u,
     0xd6f6d6a7u, 0x1a5cd639u, 0x94d3d1dau, 0x5879d144u, 0x52bcd85du, 0x9e16d8c3u, 0x1099df20u, 0xdc33dfbeu,
     0x0513cd12u, 0xc9b9cd8cu, 0x4736ca6fu, 0x8b9ccaf1u, 0x8159c3e8u, 0x4df3c376u, 0xc37cc495u, 0x0fd6c40bu,
     0x7aa64737u, 0xb60c47a9u, 0x3883404au, 0xf42940d4u, 0xfeec49cdu, 0x32464953u, 0xbcc94eb0u, 0x70634e2eu,
     0xa9435c82u, 0x65e95c1cu, 0xeb665bffu, 0x27cc5b61u, 0x2d095278u, 0xe1a352e6u, 0x6f2c5505u, 0xa386559bu,
     0x061d761cu, 0xcab77682u, 0x44387161u, 0x889271ffu, 0x825778e6u, 0x4efd7878u, 0xc0727f9bu, 0x0cd87f05u,
     0xd5f86da9u, 0x19526d37u, 0x97dd6ad4u, 0x5b776a4au, 0x51b26353u, 0x9d1863cdu, 0x1397642eu, 0xdf3d64b0u,
     0x83d02561u, 0x4f7a25ffu, 0xc1f5221cu, 0x0d5f2282u, 0x079a2b9bu, 0xcb302b05u, 0x45bf2ce6u, 0x89152c78u,
     0x50353ed4u, 0x9c9f3e4au, 0x121039a9u, 0xdeba3937u, 0xd47f302eu, 0x18d530b0u, 0x965a3753u, 0x5af037cdu,
     0xff6b144au, 0x33c114d4u, 0xbd4e1337u, 0x71e413a9u, 0x7b211ab0u, 0xb78b1a2eu, 0x39041dcdu, 0xf5ae1d53u,
     0x2c8e0fffu, 0xe0240f61u, 0x6eab0882u, 0xa201081cu, 0xa8c40105u, 0x646e019bu, 0xeae10678u, 0x264b06e6u}
};
static uint32_t swpm__crc_update(uint32_t c, const uint8_t *p, uint64_t n) {
    const uint32_t(*t)[256] = swpm__crc_table;
    while (n >= 8) {
        uint32_t lo = c ^ swpm__u32(p), hi = swpm__u32(p + 4);
        c = t[7][lo & 0xFF] ^ t[6][(lo >> 8) & 0xFF] ^ t[5][(lo >> 16) & 0xFF] ^ t[4][lo >> 24] ^
            t[3][hi & 0xFF] ^ t[2][(hi >> 8) & 0xFF] ^ t[1][(hi >> 16) & 0xFF] ^ t[0][hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) c = t[0][(c ^ *p++) & 0xFFu] ^ (c >> 8);
    return c;
}

/* ---- strict UTF-8 (no overlong forms, no surrogates, <= U+10FFFF), as a strict decoder takes it ---- */
static int swpm__utf8_ok(const uint8_t *s, uint64_t n) {
    uint64_t i = 0;
    while (i < n) {
        uint32_t c = s[i];
        uint64_t need;
        uint32_t lo = 0x80, hi = 0xBF;
        if (c < 0x80) { i++; continue; }
        if (c >= 0xC2 && c <= 0xDF) need = 1;
        else if (c >= 0xE0 && c <= 0xEF) {
            need = 2;
            if (c == 0xE0) lo = 0xA0;
            if (c == 0xED) hi = 0x9F;
        } else if (c >= 0xF0 && c <= 0xF4) {
            need = 3;
            if (c == 0xF0) lo = 0x90;
            if (c == 0xF4) hi = 0x8F;
        } else return 0;
        if (need > n - i - 1) return 0;
        if (s[i + 1] < lo || s[i + 1] > hi) return 0;
        if (need >= 2 && (s[i + 2] & 0xC0) != 0x80) return 0;
        if (need >= 3 && (s[i + 3] & 0xC0) != 0x80) return 0;
        i += need + 1;
    }
    return 1;
}

/* ---- META: a strict RFC 8259 JSON validator with format.md 3.1's limits (depth 128, finite binary64) ---- */
typedef struct swpm__js {
    const uint8_t *s;
    uint64_t n;
} swpm__js;

static uint64_t swpm__ws(const swpm__js *j, uint64_t p) {
    while (p < j->n && (j->s[p] == ' ' || j->s[p] == '\t' || j->s[p] == '\n' || j->s[p] == '\r')) p++;
    return p;
}
static int swpm__hex4(const swpm__js *j, uint64_t p, uint32_t *v) {
    uint32_t i, x = 0;
    if (p > j->n || j->n - p < 4) return 0;
    for (i = 0; i < 4; i++) {
        uint8_t c = j->s[p + i];
        x <<= 4;
        if (c >= '0' && c <= '9') x |= (uint32_t)(c - '0');
        else if (c >= 'a' && c <= 'f') x |= (uint32_t)(c - 'a' + 10);
        else if (c >= 'A' && c <= 'F') x |= (uint32_t)(c - 'A' + 10);
        else return 0;
    }
    *v = x;
    return 1;
}
/* A string at p (s[p] == '"'): 1 and *end past its closing quote if valid (UTF-8 is checked beforehand). */
static int swpm__jstring(const swpm__js *j, uint64_t p, uint64_t *end) {
    uint32_t v;
    p++;
    while (p < j->n) {
        uint8_t c = j->s[p];
        if (c == '"') { *end = p + 1; return 1; }
        if (c < 0x20) return 0;
        if (c == '\\') {
            if (p + 1 >= j->n) return 0;
            c = j->s[p + 1];
            if (c == 'u') {
                if (!swpm__hex4(j, p + 2, &v)) return 0;
                p += 6;
            } else if (c == '"' || c == '\\' || c == '/' || c == 'b' || c == 'f' || c == 'n' || c == 'r' ||
                       c == 't') {
                p += 2;
            } else return 0;
        } else p++;
    }
    return 0;
}
/* Next code point of a validated string (p inside it); 0xFFFFFFFF at its closing quote. Escaped surrogate
 * pairs join into one code point, unpaired ones stay (a JSON string is a sequence of code points). */
static uint32_t swpm__jnext(const swpm__js *j, uint64_t *p) {
    uint8_t c = j->s[*p];
    uint32_t v = 0, w = 0; /* (set by swpm__hex4; initialised for -O3 -Wmaybe-uninitialized) */
    if (c == '"') return 0xFFFFFFFFu;
    if (c == '\\') {
        c = j->s[*p + 1];
        if (c != 'u') {
            *p += 2;
            switch (c) {
            case 'b': return 8;
            case 'f': return 12;
            case 'n': return 10;
            case 'r': return 13;
            case 't': return 9;
            default: return c;
            }
        }
        swpm__hex4(j, *p + 2, &v);
        *p += 6;
        if (v >= 0xD800 && v <= 0xDBFF && *p + 1 < j->n && j->s[*p] == '\\' && j->s[*p + 1] == 'u' &&
            swpm__hex4(j, *p + 2, &w) && w >= 0xDC00 && w <= 0xDFFF) {
            *p += 6;
            return 0x10000u + ((v - 0xD800u) << 10) + (w - 0xDC00u);
        }
        return v;
    }
    if (c < 0x80) { *p += 1; return c; }
    if (c < 0xE0) { v = ((uint32_t)(c & 0x1F) << 6) | (j->s[*p + 1] & 0x3Fu); *p += 2; return v; }
    if (c < 0xF0) {
        v = ((uint32_t)(c & 0x0F) << 12) | ((uint32_t)(j->s[*p + 1] & 0x3F) << 6) | (j->s[*p + 2] & 0x3Fu);
        *p += 3;
        return v;
    }
    v = ((uint32_t)(c & 0x07) << 18) | ((uint32_t)(j->s[*p + 1] & 0x3F) << 12) |
        ((uint32_t)(j->s[*p + 2] & 0x3F) << 6) | (j->s[*p + 3] & 0x3Fu);
    *p += 4;
    return v;
}
/* Equal code point sequences of two validated strings at a and b (each at its opening quote). */
static int swpm__jstreq(const swpm__js *j, uint64_t a, uint64_t b) {
    uint32_t x, y;
    a++;
    b++;
    do {
        x = swpm__jnext(j, &a);
        y = swpm__jnext(j, &b);
        if (x != y) return 0;
    } while (x != 0xFFFFFFFFu);
    return 1;
}
/* A validated string at a equal to the ASCII text t. */
static int swpm__jstreq_lit(const swpm__js *j, uint64_t a, const char *t) {
    uint32_t x;
    a++;
    for (;; t++) {
        x = swpm__jnext(j, &a);
        if (*t == 0) return x == 0xFFFFFFFFu;
        if (x != (uint32_t)(uint8_t)*t) return 0;
    }
}

/* 2^1024 - 2^970: the least magnitude that rounds to infinity in binary64 (round to nearest even). */
static const char swpm__inf_digits[] =
    "179769313486231580793728971405303415079934132710037826936173778980444968292764750946649017977587207096330286416692887910946555547851940402630657488671505820681908902000708383676273854845817711531764475730270069855571366959622842914819860834936475292719074168444365510704342711559699508093042880177904174497792";

/* A number at p: 1 if it is RFC 8259's grammar and finite in binary64 (format.md 3.1). *is_int: no
 * fraction or exponent; then *neg and *value (saturated at 2^32) describe the integer. */
static int swpm__jnumber(const swpm__js *j, uint64_t p, uint64_t *end, int *is_int, int *neg, uint64_t *value) {
    uint64_t int_start, int_len, frac_start = 0, frac_len = 0, q, z, i;
    int64_t exp10 = 0, e;
    int eneg = 0, cmp;
    *neg = 0;
    *is_int = 1;
    if (p < j->n && j->s[p] == '-') { *neg = 1; p++; }
    if (p >= j->n || j->s[p] < '0' || j->s[p] > '9') return 0;
    int_start = p;
    if (j->s[p] == '0') p++;
    else while (p < j->n && j->s[p] >= '0' && j->s[p] <= '9') p++;
    int_len = p - int_start;
    if (p < j->n && j->s[p] == '.') {
        *is_int = 0;
        p++;
        frac_start = p;
        while (p < j->n && j->s[p] >= '0' && j->s[p] <= '9') p++;
        frac_len = p - frac_start;
        if (frac_len == 0) return 0;
    }
    if (p < j->n && (j->s[p] == 'e' || j->s[p] == 'E')) {
        uint64_t es;
        *is_int = 0;
        p++;
        if (p < j->n && (j->s[p] == '+' || j->s[p] == '-')) { eneg = j->s[p] == '-'; p++; }
        es = p;
        while (p < j->n && j->s[p] >= '0' && j->s[p] <= '9') {
            if (exp10 < 1000000000000000LL) exp10 = exp10 * 10 + (j->s[p] - '0'); /* saturates: lengths < 2^50 */
            p++;
        }
        if (p == es) return 0;
        if (eneg) exp10 = -exp10;
    }
    *end = p;
    /* value = 0.D x 10^(int_len + exp10) with D the int then fraction digits; drop D's leading zeros */
    z = 0;
    for (i = 0; i < int_len + frac_len; i++) {
        uint8_t c = i < int_len ? j->s[int_start + i] : j->s[frac_start + i - int_len];
        if (c != '0') break;
        z++;
    }
    *value = 0;
    if (*is_int) {
        for (i = 0; i < int_len; i++) {
            *value = *value * 10 + (uint64_t)(j->s[int_start + i] - '0');
            if (*value > 0xFFFFFFFFull) { *value = 0x100000000ull; break; }
        }
    }
    if (z == int_len + frac_len) return 1; /* zero */
    e = (int64_t)int_len - (int64_t)z + exp10;
    if (e < 309) return 1;
    if (e > 309) return 0;
    cmp = 0; /* compare 0.D' with 0.(inf_digits) digit by digit */
    for (i = 0, q = z; i < 309; i++, q++) {
        uint8_t c = '0';
        if (q < int_len + frac_len) c = q < int_len ? j->s[int_start + q] : j->s[frac_start + q - int_len];
        if (c != (uint8_t)swpm__inf_digits[i]) { cmp = c < (uint8_t)swpm__inf_digits[i] ? -1 : 1; break; }
    }
    return cmp < 0; /* equal to the threshold rounds (ties to even) to infinity too */
}

/* Skip a validated value at p (no checks): its end. */
static uint64_t swpm__jskip(const swpm__js *j, uint64_t p) {
    uint64_t depth = 0;
    do {
        uint8_t c = j->s[p];
        if (c == '"') {
            p++;
            while (j->s[p] != '"') p += j->s[p] == '\\' ? 2 : 1;
            p++;
        } else if (c == '{' || c == '[') { depth++; p++; }
        else if (c == '}' || c == ']') { depth--; p++; }
        else if (c == ',' || c == ':' || c == ' ' || c == '\t' || c == '\n' || c == '\r') p++;
        else {
            while (p < j->n && j->s[p] != ',' && j->s[p] != '}' && j->s[p] != ']' && j->s[p] != ' ' &&
                   j->s[p] != '\t' && j->s[p] != '\n' && j->s[p] != '\r')
                p++;
        }
    } while (depth > 0);
    return p;
}

/* Validate a value at p at the given depth (arrays and objects count, the top-level object is 1). */
static int swpm__jvalue(const swpm__js *j, uint64_t p, unsigned depth, uint64_t *end) {
    uint64_t q, v;
    int a, b;
    if (p >= j->n) return 0;
    switch (j->s[p]) {
    case '"': return swpm__jstring(j, p, end);
    case 't':
        if (j->n - p >= 4 && memcmp(j->s + p, "true", 4) == 0) { *end = p + 4; return 1; }
        return 0;
    case 'f':
        if (j->n - p >= 5 && memcmp(j->s + p, "false", 5) == 0) { *end = p + 5; return 1; }
        return 0;
    case 'n':
        if (j->n - p >= 4 && memcmp(j->s + p, "null", 4) == 0) { *end = p + 4; return 1; }
        return 0;
    case '[':
        if (depth + 1 > 128) return 0;
        p = swpm__ws(j, p + 1);
        if (p < j->n && j->s[p] == ']') { *end = p + 1; return 1; }
        for (;;) {
            if (!swpm__jvalue(j, p, depth + 1, &q)) return 0;
            p = swpm__ws(j, q);
            if (p >= j->n) return 0;
            if (j->s[p] == ']') { *end = p + 1; return 1; }
            if (j->s[p] != ',') return 0;
            p = swpm__ws(j, p + 1);
        }
    case '{': {
        uint64_t first_key;
        if (depth + 1 > 128) return 0;
        p = swpm__ws(j, p + 1);
        if (p < j->n && j->s[p] == '}') { *end = p + 1; return 1; }
        first_key = p;
        for (;;) {
            uint64_t k;
            if (p >= j->n || j->s[p] != '"' || !swpm__jstring(j, p, &q)) return 0;
            /* no duplicate key (format.md 3.1): compare with the keys before it */
            for (k = first_key; k < p;) {
                if (swpm__jstreq(j, k, p)) return 0;
                k = swpm__ws(j, swpm__jskip(j, k));      /* key */
                k = swpm__ws(j, k + 1);                  /* ':' */
                k = swpm__ws(j, swpm__jskip(j, k));      /* value */
                k = swpm__ws(j, k + 1);                  /* ',' */
            }
            p = swpm__ws(j, q);
            if (p >= j->n || j->s[p] != ':') return 0;
            p = swpm__ws(j, p + 1);
            if (!swpm__jvalue(j, p, depth + 1, &q)) return 0;
            p = swpm__ws(j, q);
            if (p >= j->n) return 0;
            if (j->s[p] == '}') { *end = p + 1; return 1; }
            if (j->s[p] != ',') return 0;
            p = swpm__ws(j, p + 1);
        }
    }
    default:
        return swpm__jnumber(j, p, end, &a, &b, &v);
    }
}

/* In a validated object at p, the value of key (ASCII): 1 and *val at its first byte, else 0. */
static int swpm__jfind(const swpm__js *j, uint64_t p, const char *key, uint64_t *val) {
    p = swpm__ws(j, p + 1);
    if (j->s[p] == '}') return 0;
    for (;;) {
        int hit = swpm__jstreq_lit(j, p, key);
        p = swpm__ws(j, swpm__jskip(j, p));
        p = swpm__ws(j, p + 1);
        if (hit) { *val = p; return 1; }
        p = swpm__ws(j, swpm__jskip(j, p));
        if (j->s[p] == '}') return 0;
        p = swpm__ws(j, p + 1);
    }
}

/* ---- chunk kinds (format.md 2.3) ---- */
enum { SWPM__META, SWPM__LODS, SWPM__SMAP, SWPM__RCNT, SWPM__WREC, SWPM__VREC, SWPM__SKIP, SWPM__SREC,
       SWPM__MLVL, SWPM__MREC, SWPM__INDX, SWPM__VERT, SWPM__KINDS };
static const char swpm__kind_names[SWPM__KINDS][5] = {"META", "LODS", "SMAP", "RCNT", "WREC", "VREC",
                                                      "SKIP", "SREC", "MLVL", "MREC", "INDX", "VERT"};
/* allowed kinds per encoding bit index (1 vanilla .. 4 mixed), and the critical ones in streaming order */
static const int swpm__critical_order[5][8] = {
    {-1},
    {SWPM__META, SWPM__LODS, SWPM__RCNT, SWPM__VREC, SWPM__INDX, SWPM__VERT, -1},
    {SWPM__META, SWPM__LODS, SWPM__WREC, SWPM__INDX, SWPM__VERT, -1},
    {SWPM__META, SWPM__LODS, SWPM__RCNT, SWPM__SKIP, SWPM__SREC, SWPM__INDX, SWPM__VERT, -1},
    {SWPM__META, SWPM__LODS, SWPM__RCNT, SWPM__MLVL, SWPM__MREC, SWPM__INDX, SWPM__VERT, -1},
};
static int swpm__allowed(int enc, int kind) {
    int i;
    if (kind == SWPM__SMAP) return 1;
    for (i = 0; swpm__critical_order[enc][i] >= 0; i++)
        if (swpm__critical_order[enc][i] == kind) return 1;
    return 0;
}

/* The first position in [from, to) of the idx array x whose value is >= limit, a strip pool's restart index
 * exempt; to if none. Blocks of 64 are scanned without an early exit (a loop the compiler can vectorise),
 * and only a block that holds one is searched again. */
static uint64_t swpm__first_at_least(const uint8_t *x, uint32_t W, uint64_t from, uint64_t to, uint64_t limit,
                                     int exempt, uint64_t restart) {
    uint64_t i, j, e;
    uint32_t lim, rst, noex, bad;
    if (from >= to || limit > 0xFFFFFFFFull) return to; /* no idx value reaches 2^32 */
    lim = (uint32_t)limit;
    noex = !exempt || restart > 0xFFFFFFFFull;
    rst = noex ? 0 : (uint32_t)restart;
    for (i = from; i < to; i = e) {
        e = to - i > 64 ? i + 64 : to;
        bad = 0;
        if (W == 2) {
            for (j = i; j < e; j++) {
                uint32_t v = swpm__u16(x + 2 * j);
                bad |= (uint32_t)(v >= lim) & (noex | (uint32_t)(v != rst));
            }
        } else {
            for (j = i; j < e; j++) {
                uint32_t v = swpm__u32(x + 4 * j);
                bad |= (uint32_t)(v >= lim) & (noex | (uint32_t)(v != rst));
            }
        }
        if (bad)
            for (j = i; j < e; j++) {
                uint32_t v = swpm__uw(x + W * j, W);
                if (v >= lim && (noex || v != rst)) return j;
            }
    }
    return to;
}

/* 1 if INDX position j ends a non-degenerate strip triangle: j-2, j-1, j in one strip (no restart index
 * among them) and three distinct values (format.md 3.5, 3.7). */
static uint64_t swpm__ends_triangle(const uint8_t *x, uint32_t W, uint64_t restart, uint64_t j) {
    uint64_t a, b, c;
    if (j < 2) return 0;
    a = swpm__uw(x + (j - 2) * W, W);
    b = swpm__uw(x + (j - 1) * W, W);
    c = swpm__uw(x + j * W, W);
    return a != restart && b != restart && c != restart && a != b && b != c && a != c;
}

static swpm_result swpm__err(const char *code, uint64_t offset) {
    swpm_result r;
    r.code = code;
    r.offset = offset;
    r.has_offset = 1;
    r.need = 0;
    r.need_start = 0;
    return r;
}
static void swpm__put(uint8_t *p, uint32_t w, uint64_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    if (w == 4) {
        p[2] = (uint8_t)(v >> 16);
        p[3] = (uint8_t)(v >> 24);
    }
}

static const uint32_t swpm__elem_sizes[10] = {0, 1, 1, 2, 2, 4, 4, 2, 4, 8};

/* VERT layout (format.md 3.3), in the order the spec gives; fills V, A, stride, data_offset. */
static swpm_result swpm__vert(const uint8_t *p, uint64_t len, uint64_t entry, uint64_t off, swpm_file *f) {
    uint32_t V, A, stride, data_offset, i, k;
    uint64_t names_start;
    swpm_result ok = {NULL, 0, 0, 0, 0};
    if (len < 16) return swpm__err("SWPM_CHUNK_BAD_LENGTH", entry + 16);
    V = swpm__u32(p);
    A = swpm__u32(p + 4);
    stride = swpm__u32(p + 8);
    data_offset = swpm__u32(p + 12);
    names_start = 16 + 16 * (uint64_t)A;
    if (names_start > len) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", off + 4);
    if (A > 255 || stride < 12 || stride % 4 || data_offset % 8 || data_offset < names_start || data_offset > len)
        return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
    if ((uint64_t)V * stride > len - data_offset) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", off);
    if ((uint64_t)V * stride != len - data_offset) return swpm__err("SWPM_CHUNK_BAD_LENGTH", entry + 16);
    for (i = 0; i < A; i++) {
        const uint8_t *d = p + 16 + 16 * (uint64_t)i;
        uint32_t no = swpm__u32(d), nl = swpm__u16(d + 4), et = d[6], comps = d[7], ao = swpm__u32(d + 8), es;
        if (nl < 1 || no < names_start || (uint64_t)no + nl > data_offset) return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        if (!swpm__utf8_ok(p + no, nl)) return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        for (k = 0; k < i; k++) {
            const uint8_t *e = p + 16 + 16 * (uint64_t)k;
            if (swpm__u16(e + 4) == nl && memcmp(p + swpm__u32(e), p + no, nl) == 0)
                return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        }
        if (et < 1 || et > 9 || comps < 1) return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        es = swpm__elem_sizes[et];
        if (ao % es || (uint64_t)ao + (uint64_t)comps * es > stride || stride % es)
            return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
    }
    /* attributes overlap neither each other nor the position [0, 12) */
    for (i = 0; i < A; i++) {
        const uint8_t *d = p + 16 + 16 * (uint64_t)i;
        uint64_t a0 = swpm__u32(d + 8), a1 = a0 + (uint64_t)d[7] * swpm__elem_sizes[d[6]];
        if (a0 < 12) return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        for (k = 0; k < i; k++) {
            const uint8_t *e = p + 16 + 16 * (uint64_t)k;
            uint64_t b0 = swpm__u32(e + 8), b1 = b0 + (uint64_t)e[7] * swpm__elem_sizes[e[6]];
            if (a0 < b1 && b0 < a1) return swpm__err("SWPM_VERT_BAD_LAYOUT", off);
        }
    }
    f->vert = p;
    f->vertex_count = V;
    f->attribute_count = A;
    f->stride = stride;
    f->data_offset = data_offset;
    return ok;
}

static swpm_result swpm__vanilla(swpm_file *f, const uint8_t *bytes, const uint64_t *pe, const uint64_t *pl,
                                 void *scratch, size_t scratch_bytes);
static swpm_result swpm__levels(swpm_file *f, const uint8_t *bytes, const uint64_t *pe, const uint64_t *pl,
                                void *scratch, size_t scratch_bytes);
static const char *const swpm__encoding_names[5] = {"", "vanilla", "sliding-window", "skip-strip", "mixed"};

static swpm_result swpm__open(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                              size_t scratch_bytes, int prefix, const swpm_range *held, uint64_t held_count);

swpm_result swpm_open(const uint8_t *bytes, size_t length, swpm_file *file) {
    return swpm__open(bytes, length, file, NULL, 0, 0, NULL, 0);
}
swpm_result swpm_open_ex(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                         size_t scratch_bytes) {
    return swpm__open(bytes, length, file, scratch, scratch_bytes, 0, NULL, 0);
}
swpm_result swpm_open_prefix(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                             size_t scratch_bytes) {
    return swpm__open(bytes, length, file, scratch, scratch_bytes, 1, NULL, 0);
}
swpm_result swpm_open_ranges(const uint8_t *bytes, size_t length, const swpm_range *held, size_t held_count,
                             swpm_file *file, void *scratch, size_t scratch_bytes) {
    return swpm__open(bytes, length, file, scratch, scratch_bytes, 2, held, (uint64_t)held_count);
}
/* The first byte of [a, b) not held (b if all are): in `held` (unsorted, may overlap or abut), or without
 * ranges in [0, len). Quadratic in the ranges: a caller holds a few (SMAP's bands name at most 16). */
static uint64_t swpm__held_to(const swpm_range *held, uint64_t n, uint64_t len, uint64_t a, uint64_t b) {
    uint64_t i, to;
    if (held == NULL) return b <= len ? b : a > len ? a : len;
    while (a < b) {
        for (to = a, i = 0; i < n; i++)
            if (held[i].offset <= a && a - held[i].offset < held[i].length && held[i].offset + held[i].length > to)
                to = held[i].offset + held[i].length;
        if (to == a) return a;
        a = to;
    }
    return b;
}
/* Whether a byte of [a, b) at hand is non-zero (padding, format.md 1): of [0, len) without ranges, else of the
 * held ranges only, each read in its part of [a, b): a gap far longer than the ranges (one held at 2^40 of a
 * file whose file_size says 2^41) costs the bytes they hold, and no byte not held is read. */
static int swpm__nonzero(const uint8_t *bytes, const swpm_range *held, uint64_t n, uint64_t len, uint64_t a,
                         uint64_t b) {
    uint64_t i, g, lo, hi;
    if (b > len) b = len;
    if (held == NULL) {
        for (g = a; g < b; g++)
            if (bytes[g]) return 1;
        return 0;
    }
    for (i = 0; i < n; i++) { /* (ranges inside [0, len): checked when opened) */
        if (!held[i].length) continue;
        lo = held[i].offset > a ? held[i].offset : a;
        hi = held[i].offset + held[i].length < b ? held[i].offset + held[i].length : b;
        for (g = lo; g < hi; g++)
            if (bytes[g]) return 1;
    }
    return 0;
}
/* SWPM_RANGES_NOT_HELD: at the first byte of [start, end) not held, with that range to fetch */
static swpm_result swpm__not_held(const swpm_range *held, uint64_t n, uint64_t len, uint64_t start, uint64_t end) {
    swpm_result r = swpm__err("SWPM_RANGES_NOT_HELD", swpm__held_to(held, n, len, start, end));
    if (r.offset >= end) r.offset = start > len ? start : len; /* (cannot happen: the caller found a gap) */
    r.need_start = start;
    r.need = end;
    return r;
}
static swpm_result swpm__check_drawn(const swpm_file *f);
/* SWPM_PREFIX_TOO_SHORT: reported at the prefix's end, with the length it needs */
static swpm_result swpm__short(uint64_t len, uint64_t need) {
    swpm_result r = swpm__err("SWPM_PREFIX_TOO_SHORT", len);
    r.need = need;
    return r;
}

static swpm_result swpm__open(const uint8_t *bytes, size_t length, swpm_file *file, void *scratch,
                              size_t scratch_bytes, int prefix, const swpm_range *held, uint64_t held_count) {
    swpm_file f;
    const int ranges = prefix == 2;
    swpm_result ok = {NULL, 0, 0, 0, 0};
    uint64_t len = (uint64_t)length, eof, table_offset, file_size, table_end, end, last = 0;
    uint32_t header_size, features, count, enc_bits, i, W, O;
    int enc = 0, one_encoding, have_last = 0, streaming;
    int64_t first[SWPM__KINDS];
    uint32_t crc;
    uint8_t zero4[4] = {0, 0, 0, 0};
    static const uint8_t magic[8] = {0x53, 0x57, 0x50, 0x4D, 0x0D, 0x0A, 0x1A, 0x0A};

    memset(&f, 0, sizeof f);
    if (ranges) { /* format.md 4.2 step 1: the header held; ranges inside the buffer (else the caller's error) */
        uint64_t top = 0, q;
        swpm_result bad = {SWPM_READER_BAD_RANGES, 0, 0, 0, 0};
        if (held_count && held == NULL) return bad;
        for (q = 0; q < held_count; q++) {
            if (!held[q].length) continue; /* holds no byte: never read, wherever it lies */
            if (held[q].length > len || held[q].offset > len - held[q].length) return bad;
            if (held[q].offset + held[q].length > top) top = held[q].offset + held[q].length;
        }
        if (swpm__held_to(held, held_count, len, 0, 64) < 64) {
            if (swpm__held_to(held, held_count, len, 0, 8) == 8 && memcmp(bytes, magic, 8) != 0)
                return swpm__err("SWPM_HEADER_BAD_MAGIC", 0);
            return swpm__not_held(held, held_count, len, 0, 64);
        }
        len = top; /* bytes past the last held byte are not the file's */
        if (swpm__u64(bytes + 40) < 64) { /* the header lies past file_size: the file's error (4.2 step 1), read
                                              as format.md 5 reads the bytes to the last held one (its table
                                              ends past file_size: no byte past the header is read) */
            held = NULL;
            prefix = 0;
        } else if (top > swpm__u64(bytes + 40)) {
            return bad; /* a range past file_size */
        } else if (swpm__held_to(held, held_count, len, 0, len) == len && len == swpm__u64(bytes + 40)) {
            held = NULL; /* every byte held: the whole file, read as format.md 5 reads it */
            prefix = 0;
        } else if (memcmp(bytes, magic, 8) == 0 && swpm__u16(bytes + 8) == 1) {
            uint64_t hs = swpm__u32(bytes + 12), fs = swpm__u64(bytes + 40);
            if (hs >= 64 && hs <= fs && hs > len) return swpm__not_held(held, held_count, len, 0, hs);
        }
    }
    if (prefix != 2) held = NULL, held_count = 0;
    /* ---- step 1: header (format.md 2.1, 5) ---- */
    if (len < 64) {
        if (len >= 8 && memcmp(bytes, magic, 8) != 0) return swpm__err("SWPM_HEADER_BAD_MAGIC", 0);
        if (prefix) return swpm__short(len, 64); /* file_size is not there yet */
        return swpm__err("SWPM_HEADER_TRUNCATED", 0);
    }
    if (memcmp(bytes, magic, 8) != 0) return swpm__err("SWPM_HEADER_BAD_MAGIC", 0);
    f.major = swpm__u16(bytes + 8);
    f.minor = swpm__u16(bytes + 10);
    if (f.major != 1) return swpm__err("SWPM_HEADER_UNSUPPORTED_MAJOR", 8);
    header_size = swpm__u32(bytes + 12);
    file_size = swpm__u64(bytes + 40);
    streaming = (prefix == 1 && file_size > len) || prefix == 2; /* a prefix of a longer file (4.1), or ranges
                                                                    (4.2): it ends at file_size */
    if (streaming && header_size >= 64 && header_size <= file_size && header_size > len)
        return swpm__short(len, header_size);
    if (header_size < 64 || header_size > len) return swpm__err("SWPM_HEADER_BAD_SIZE", 12);
    features = swpm__u32(bytes + 20);
    if (features & ~0x7Fu) return swpm__err("SWPM_HEADER_UNKNOWN_FEATURE", 20);
    enc_bits = features & 0x1Eu;
    if (enc_bits != 0x02 && enc_bits != 0x04 && enc_bits != 0x08 && enc_bits != 0x10)
        return swpm__err("SWPM_HEADER_BAD_ENCODING", 20);
    if ((features & SWPM_FEATURE_SW_STRIPS) && !(features & SWPM_FEATURE_SLIDING_WINDOW))
        return swpm__err("SWPM_HEADER_STRIPS_NOT_SLIDING", 20);
    if ((features & SWPM_FEATURE_OFFSET32) && (features & SWPM_FEATURE_INDEX32))
        return swpm__err("SWPM_HEADER_OFFSET32_WITH_INDEX32", 20);
    enc = enc_bits == 0x02 ? 1 : enc_bits == 0x04 ? 2 : enc_bits == 0x08 ? 3 : 4;
    one_encoding = 1; /* a header without exactly one encoding bit was rejected above */
    /* reserved fields: warnings only */
    if (file_size > len && !streaming) return swpm__err("SWPM_FILE_SIZE_MISMATCH", 40);
    eof = file_size < len || streaming ? file_size : len; /* bytes after file_size are ignored (a warning) */
    table_offset = swpm__u64(bytes + 32);
    if (table_offset < header_size || table_offset % 8) return swpm__err("SWPM_TABLE_BAD_OFFSET", 32);
    count = swpm__u32(bytes + 24);
    if (count > 1024) return swpm__err("SWPM_TABLE_TOO_LARGE", 24);
    if (table_offset > eof || 32 * (uint64_t)count > eof - table_offset) return swpm__err("SWPM_TABLE_TRUNCATED", 24);
    table_end = table_offset + 32 * (uint64_t)count;
    if (prefix == 2 && swpm__held_to(held, held_count, len, 0, table_end) < table_end)
        return swpm__not_held(held, held_count, len, 0, table_end);
    if (table_end > len) return swpm__short(len, table_end); /* (a prefix only: else eof <= len) */
    crc = swpm__crc_update(0xFFFFFFFFu, bytes, 48);
    crc = swpm__crc_update(crc, zero4, 4);
    crc = swpm__crc_update(crc, bytes + 52, table_end - 52) ^ 0xFFFFFFFFu;
    if (crc != swpm__u32(bytes + 48)) return swpm__err("SWPM_CHECKSUM_MISMATCH", 48);
    for (end = header_size; end < table_offset; end++) /* padding [header_size, table_offset) */
        if (bytes[end]) return swpm__err("SWPM_PADDING_NONZERO", header_size);

    /* ---- step 2: chunk table (format.md 2.2, 2.3, 5) ---- */
    for (i = 0; i < SWPM__KINDS; i++) first[i] = -1;
    end = table_end;
    for (i = 0; i < count; i++) {
        uint64_t eo = table_offset + 32 * (uint64_t)i, off = swpm__u64(bytes + eo + 8), clen = swpm__u64(bytes + eo + 16);
        uint32_t flags = swpm__u32(bytes + eo + 4);
        int type_ok = 1, bounds_ok, kind = -1, k;
        for (k = 0; k < 4; k++) {
            uint8_t c = bytes[eo + (uint64_t)k];
            if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'))) type_ok = 0;
        }
        if (!type_ok) return swpm__err("SWPM_CHUNK_BAD_TYPE", eo);
        bounds_ok = off <= eof && clen <= eof - off;
        if (!bounds_ok) return swpm__err("SWPM_CHUNK_OUT_OF_BOUNDS", eo + 8);
        if (off % 8) return swpm__err("SWPM_CHUNK_MISALIGNED", eo + 8);
        if (have_last && off < last) return swpm__err("SWPM_CHUNK_OUT_OF_ORDER", eo + 8);
        if (off < end) return swpm__err("SWPM_CHUNK_OVERLAP", eo + 8);
        if (end < off && swpm__nonzero(bytes, held, held_count, len, end, off < eof ? off : eof))
            return swpm__err("SWPM_PADDING_NONZERO", end); /* (a prefix or ranges: the bytes held) */
        have_last = 1;
        last = off;
        end = off + clen; /* in bounds: no wrap */
        if (swpm__held_to(held, held_count, len, off, off + clen) == off + clen) { /* (a payload not wholly held
                                                                      waits for the whole file) */
            crc = swpm__crc_update(swpm__crc_update(0xFFFFFFFFu, bytes + eo, 4), bytes + off, clen) ^ 0xFFFFFFFFu;
            if (crc != swpm__u32(bytes + eo + 24)) return swpm__err("SWPM_CHUNK_CRC_MISMATCH", eo + 24);
        }
        for (k = 0; k < SWPM__KINDS; k++)
            if (memcmp(bytes + eo, swpm__kind_names[k], 4) == 0) kind = k;
        if (kind < 0) {
            if (flags & 1u) return swpm__err("SWPM_CHUNK_UNKNOWN_CRITICAL", eo);
            continue; /* unknown ancillary: ignored */
        }
        if ((flags & 1u) != (kind == SWPM__SMAP ? 0u : 1u)) return swpm__err("SWPM_CHUNK_BAD_FLAGS", eo + 4);
        if (one_encoding && !swpm__allowed(enc, kind)) return swpm__err("SWPM_CHUNK_NOT_ALLOWED", eo);
        if (first[kind] >= 0) return swpm__err("SWPM_CHUNK_DUPLICATE", eo);
        first[kind] = (int64_t)i;
    }
    if (end < eof && swpm__nonzero(bytes, held, held_count, len, end, eof)) /* padding after the last payload */
        return swpm__err("SWPM_PADDING_NONZERO", end);                       /* at the gap's start */
    for (i = 0; swpm__critical_order[enc][i] >= 0; i++)
        if (first[swpm__critical_order[enc][i]] < 0) {
            swpm_result r = {"SWPM_CHUNK_MISSING", 0, 0, 0, 0};
            return r;
        }
    if (prefix == 2) { /* 4.2 step 3: every byte before INDX, VERT's bytes before its records, and every other
                          table it decodes (one after INDX: 4.2, the order of 2.3, as kinds are numbered) */
        uint64_t io = swpm__u64(bytes + table_offset + 32 * (uint64_t)first[SWPM__INDX] + 8), vo, vl, need;
        uint64_t eo = table_offset + 32 * (uint64_t)first[SWPM__VERT];
        int k;
        if (swpm__held_to(held, held_count, len, 0, io) < io) return swpm__not_held(held, held_count, len, 0, io);
        vo = swpm__u64(bytes + eo + 8);
        vl = swpm__u64(bytes + eo + 16);
        need = vo + (vl < 16 ? vl : 16);
        if (swpm__held_to(held, held_count, len, vo, need) == need && vl >= 16) {
            uint64_t data = swpm__u32(bytes + vo + 12);
            need = vo + (data < 16 ? 16 : data < vl ? data : vl);
        }
        if (swpm__held_to(held, held_count, len, vo, need) < need)
            return swpm__not_held(held, held_count, len, vo, need);
        for (k = 0; k < SWPM__KINDS; k++)
            if (first[k] >= 0 && k != SWPM__INDX && k != SWPM__VERT && k != SWPM__SMAP) {
                uint64_t e2 = table_offset + 32 * (uint64_t)first[k], o2 = swpm__u64(bytes + e2 + 8);
                uint64_t l2 = swpm__u64(bytes + e2 + 16);
                if (swpm__held_to(held, held_count, len, o2, o2 + l2) < o2 + l2)
                    return swpm__not_held(held, held_count, len, o2, o2 + l2);
            }
        f.indx_partial = swpm__held_to(held, held_count, len, io, io + swpm__u64(bytes + table_offset + 32 *
                                       (uint64_t)first[SWPM__INDX] + 16)) < io + swpm__u64(bytes + table_offset +
                                       32 * (uint64_t)first[SWPM__INDX] + 16);
        f.ranges = held;
        f.range_count = held_count;
    } else if (streaming) { /* 4.1: VERT last, and the prefix holds every byte before its vertex records */
        uint64_t eo = table_offset + 32 * (uint64_t)(count - 1), vo, vl, need;
        if (memcmp(bytes + eo, "VERT", 4) != 0) return swpm__err("SWPM_PREFIX_NOT_STREAMABLE", eo);
        vo = swpm__u64(bytes + eo + 8); /* the first VERT (a second one was SWPM_CHUNK_DUPLICATE) */
        vl = swpm__u64(bytes + eo + 16);
        need = vo + (vl < 16 ? vl : 16);
        if (need <= len && vl >= 16) {
            uint64_t data = swpm__u32(bytes + vo + 12);
            need = vo + (data < 16 ? 16 : data < vl ? data : vl);
        }
        if (need > len) return swpm__short(len, need);
    }

    W = (features & SWPM_FEATURE_INDEX32) ? 4u : 2u;
    O = (features & (SWPM_FEATURE_INDEX32 | SWPM_FEATURE_OFFSET32)) ? 4u : 2u;
    f.bytes = bytes;
    f.length = eof;
    f.file_size = file_size;
    f.held = len;
    f.prefix = streaming && prefix == 1;
    f.features = features;
    f.index_width = W;
    f.offset_width = O;
    f.strips = (features & SWPM_FEATURE_SW_STRIPS) != 0;
    f.encoding = enc;
    {
        uint64_t pe[SWPM__KINDS], pl[SWPM__KINDS];
        for (i = 0; i < SWPM__KINDS; i++) {
            uint64_t eo = table_offset + 32 * (uint64_t)(first[i] < 0 ? 0 : first[i]);
            pe[i] = eo;
            pl[i] = first[i] < 0 ? 0 : swpm__u64(bytes + eo + 16);
        }
#define SWPM__OFF0(k) swpm__u64(bytes + pe[k] + 8)
        f.vert_entry = pe[SWPM__VERT];
        f.vert_offset = swpm__u64(bytes + pe[SWPM__VERT] + 8);
        if (first[SWPM__SMAP] >= 0 && pl[SWPM__SMAP] >= 8 && /* in a prefix: it precedes VERT; ranges: held */
            swpm__held_to(held, held_count, len, SWPM__OFF0(SWPM__SMAP), SWPM__OFF0(SWPM__SMAP) + pl[SWPM__SMAP]) ==
                SWPM__OFF0(SWPM__SMAP) + pl[SWPM__SMAP]) {
            const uint8_t *m = bytes + swpm__u64(bytes + pe[SWPM__SMAP] + 8);
            uint64_t B = swpm__u32(m), N = swpm__u32(m + 4);
            if (8 + 24 * B + 16 * N == pl[SWPM__SMAP]) {
                f.smap = m;
                f.smap_bands = B;
                f.smap_ranges = N;
            }
        }
#define SWPM__OFF(k) swpm__u64(bytes + pe[k] + 8)
        /* ---- step 3: META (3.1) ---- */
        {
            swpm__js j;
            uint64_t q, params = 0, v;
            int has_params;
            j.s = bytes + SWPM__OFF(SWPM__META);
            j.n = pl[SWPM__META];
            f.meta = j.s;
            f.meta_length = j.n;
            if (!swpm__utf8_ok(j.s, j.n)) return swpm__err("SWPM_META_BAD_JSON", SWPM__OFF(SWPM__META));
            q = swpm__ws(&j, 0);
            if (q >= j.n || j.s[q] != '{' || !swpm__jvalue(&j, q, 0, &v) || swpm__ws(&j, v) != j.n)
                return swpm__err("SWPM_META_BAD_JSON", SWPM__OFF(SWPM__META));
            has_params = swpm__jfind(&j, q, "params", &params);
            if (has_params && j.s[params] != '{') return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
            if (swpm__jfind(&j, q, "encoding", &v) &&
                !(j.s[v] == '"' && swpm__jstreq_lit(&j, v, swpm__encoding_names[enc])))
                return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
            /* 3.5: primitive "strip" exactly with SW_STRIPS (missing reads "list"); restart_index null or an
             * integer in [0, 2^32), required with SW_STRIPS */
            if (enc == 2) { /* vanilla's params are not checked (3.1) */
                int prim_strip = 0, has_rst = 0, is_int = 0, neg = 0;
                uint64_t rv = 0, e2;
                if (has_params && swpm__jfind(&j, params, "primitive", &v)) {
                    if (j.s[v] == '"' && swpm__jstreq_lit(&j, v, "strip")) prim_strip = 1;
                    else if (!(j.s[v] == '"' && swpm__jstreq_lit(&j, v, "list")))
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                }
                if (prim_strip != f.strips) return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                if (has_params && swpm__jfind(&j, params, "restart_index", &v) && j.s[v] != 'n') {
                    if (j.s[v] != '-' && (j.s[v] < '0' || j.s[v] > '9'))
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                    swpm__jnumber(&j, v, &e2, &is_int, &neg, &rv);
                    if (!is_int || (neg && rv != 0) || rv > 0xFFFFFFFFull)
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                    has_rst = 1;
                }
                if (f.strips && !has_rst) return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                f.restart_index = rv;
            }
            /* 3.7: primitive "strip" (missing) or "list"; restart_index null (missing) or an integer in
             * [0, 2^32), the strips' restart index when primitive is "strip" */
            if (enc == 3) {
                int is_int = 0, neg = 0;
                uint64_t rv = 0, e2;
                f.primitive_strip = 1;
                if (has_params && swpm__jfind(&j, params, "primitive", &v)) {
                    if (j.s[v] == '"' && swpm__jstreq_lit(&j, v, "list")) f.primitive_strip = 0;
                    else if (!(j.s[v] == '"' && swpm__jstreq_lit(&j, v, "strip")))
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                }
                if (has_params && swpm__jfind(&j, params, "restart_index", &v) && j.s[v] != 'n') {
                    if (j.s[v] != '-' && (j.s[v] < '0' || j.s[v] > '9'))
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                    swpm__jnumber(&j, v, &e2, &is_int, &neg, &rv);
                    if (!is_int || (neg && rv != 0) || rv > 0xFFFFFFFFull)
                        return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
                    f.has_restart = f.primitive_strip; /* a list ignores it (3.7) */
                    f.restart_index = rv;
                }
            }
        }
        /* ---- LODS (3.2) ---- */
        {
            const uint8_t *p = bytes + SWPM__OFF(SWPM__LODS);
            uint64_t n = pl[SWPM__LODS], L, k;
            if (n % 12) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__LODS] + 16);
            L = n / 12;
            if (L == 0) return swpm__err("SWPM_LOD_EMPTY", SWPM__OFF(SWPM__LODS));
            for (k = 1; k < L; k++)
                if (swpm__u32(p + 12 * k) > swpm__u32(p + 12 * (k - 1)))
                    return swpm__err("SWPM_LOD_NOT_MONOTONE", SWPM__OFF(SWPM__LODS) + 12 * k);
            for (k = 1; k < L; k++)
                if (swpm__u32(p + 12 * k + 4) > swpm__u32(p + 12 * (k - 1) + 4))
                    return swpm__err("SWPM_LOD_NOT_MONOTONE", SWPM__OFF(SWPM__LODS) + 12 * k);
            for (k = 0; k < L; k++) /* non-finite: exponent bits all ones */
                if ((swpm__u32(p + 12 * k + 8) & 0x7F800000u) == 0x7F800000u)
                    return swpm__err("SWPM_LOD_NOT_MONOTONE", SWPM__OFF(SWPM__LODS) + 12 * k + 8);
            for (k = 1; k < L; k++) {
                float a, b;
                uint32_t ua = swpm__u32(p + 12 * (k - 1) + 8), ub = swpm__u32(p + 12 * k + 8);
                memcpy(&a, &ua, 4);
                memcpy(&b, &ub, 4);
                if (b < a) return swpm__err("SWPM_LOD_NOT_MONOTONE", SWPM__OFF(SWPM__LODS) + 12 * k + 8);
            }
            f.lods = p;
            f.lod_count = L;
        }
        /* ---- VERT (3.3), then LODS row 0 = V ---- */
        {
            swpm_result r = swpm__vert(bytes + SWPM__OFF(SWPM__VERT), pl[SWPM__VERT], pe[SWPM__VERT],
                                       SWPM__OFF(SWPM__VERT), &f);
            if (r.code) return r;
            if (swpm__u32(f.lods) != f.vertex_count) return swpm__err("SWPM_LOD_VERTEX_COUNT", SWPM__OFF(SWPM__LODS));
        }
        if (enc == 1 || enc == 3 || enc == 4) {
            swpm_result r = enc == 1 ? swpm__vanilla(&f, bytes, pe, pl, scratch, scratch_bytes)
                                     : swpm__levels(&f, bytes, pe, pl, scratch, scratch_bytes);
            if (r.code) return r;
            r = swpm__check_drawn(&f);
            if (r.code) return r;
            *file = f;
            return ok;
        }
        /* ---- step 4, stage 0: WREC and INDX lengths (5) ---- */
        {
            uint64_t cols = f.strips ? 4 : 3, L = f.lod_count, V = f.vertex_count, k, nidx, wbase, ibase;
            uint64_t best;
            const uint8_t *w, *x;
            /* WREC = cols O L bytes, compared by division: cols O L may pass 2^64 */
            if (pl[SWPM__WREC] % (cols * O) || pl[SWPM__WREC] / (cols * O) != L) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__WREC] + 16);
            if (pl[SWPM__INDX] % W) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__INDX] + 16);
            wbase = SWPM__OFF(SWPM__WREC);
            ibase = SWPM__OFF(SWPM__INDX);
            w = bytes + wbase;
            x = bytes + ibase;
            nidx = pl[SWPM__INDX] / W;
            f.wrec = w;
            f.indx = x;
            f.index_count = nidx;
#define SWPM__W(k, c) ((uint64_t)swpm__uw(w + (cols * (k) + (c)) * O, O))
#define SWPM__X(i) ((uint64_t)swpm__uw(x + (i) * W, W))
#define SWPM__ICOUNT(k) (f.strips ? SWPM__W(k, 3) : 3 * SWPM__W(k, 1))
            /* stage (a) (3.5): a strip pool's restart index >= V */
            if (f.strips && f.restart_index < V) return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
            /* window counts against LODS: triangle_count field first, then vertex_count */
            for (k = 0; k < L; k++)
                if (SWPM__W(k, 1) != swpm__u32(f.lods + 12 * k + 4))
                    return swpm__err("SWPM_WINDOW_COUNT_MISMATCH", wbase + cols * O * k + O);
            for (k = 0; k < L; k++)
                if (SWPM__W(k, 2) != swpm__u32(f.lods + 12 * k))
                    return swpm__err("SWPM_WINDOW_COUNT_MISMATCH", wbase + cols * O * k + 2 * O);
            for (k = 1; k < L; k++)
                if (SWPM__W(k, 1) > SWPM__W(k - 1, 1))
                    return swpm__err("SWPM_WINDOW_NOT_MONOTONE", wbase + cols * O * k + O);
            for (k = 0; k < L; k++)
                if (SWPM__W(k, 0) + SWPM__ICOUNT(k) > nidx) return swpm__err("SWPM_WINDOW_OUT_OF_POOL", wbase + cols * O * k);
            /* (ranges without all of INDX, 4.2: its content waits for the whole file; swpm__check_drawn reads
             * the held windows) */
            k = f.indx_partial ? nidx : swpm__first_at_least(x, W, 0, nidx, V, f.strips, f.restart_index);
            if (k < nidx) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", ibase + W * k);
            if (f.strips && !f.indx_partial)
                for (k = 0; k < L; k++) {
                    uint64_t s = SWPM__W(k, 0);
                    if (SWPM__W(k, 3) > 0 && s > 0 && SWPM__X(s - 1) != f.restart_index)
                        return swpm__err("SWPM_WINDOW_MID_STRIP", wbase + cols * O * k);
                }
            /* stage (b): the prefix property; the lowest offending element of INDX over every window. Windows
             * are visited coarsest first with `seen` an interval of INDX that coarser windows cover: their
             * vertex counts are no larger (LODS is non-increasing), so an element there was checked against
             * a limit at most this window's and is skipped. Sliding windows overlap their neighbours, so
             * the pool is read about once, not once per window (worst case: once per window). */
            best = nidx;
            if (!f.indx_partial) {
                uint64_t seen0 = 0, seen1 = 0;
                for (k = L; k-- > 0;) {
                    uint64_t s = SWPM__W(k, 0), e = s + SWPM__ICOUNT(k), lim = SWPM__W(k, 2), i2;
                    uint64_t e1 = e < best ? e : best;
                    /* [s, e1) minus [seen0, seen1): at most two runs */
                    i2 = swpm__first_at_least(x, W, s, e1 < seen0 ? e1 : seen0, lim, f.strips, f.restart_index);
                    if (i2 < (e1 < seen0 ? e1 : seen0)) best = i2;
                    else {
                        uint64_t from = s > seen1 ? s : seen1;
                        if (from < e1) {
                            i2 = swpm__first_at_least(x, W, from, e1, lim, f.strips, f.restart_index);
                            if (i2 < e1) best = i2;
                        }
                    }
                    if (s == e) continue;
                    if (s <= seen1 && seen0 <= e && seen0 < seen1) { /* touching: the hull is covered */
                        seen0 = s < seen0 ? s : seen0;
                        seen1 = e > seen1 ? e : seen1;
                    } else { /* apart: the next (finer) windows lie next to this one */
                        seen0 = s;
                        seen1 = e;
                    }
                }
            }
            if (best < nidx) return swpm__err("SWPM_PREFIX_VIOLATION", ibase + W * best);
            /* strips: each window decodes to exactly triangle_count non-degenerate triangles. A window starts
             * a strip (stage (a)), so these are the pool's triangles whose last index lies in the window, and
             * whether position j ends one depends on INDX[j-2..j] alone: two cursors (window starts, window
             * ends) count them, moving as far as the windows move between LODs. */
            if (f.strips && !f.indx_partial) {
                uint64_t at[2] = {0, 0}, n[2] = {0, 0};
                for (k = 0; k < L; k++) {
                    uint64_t target[2], c;
                    target[0] = SWPM__W(k, 0);
                    target[1] = target[0] + SWPM__W(k, 3);
                    for (c = 0; c < 2; c++) {
                        while (at[c] < target[c]) n[c] += swpm__ends_triangle(x, W, f.restart_index, at[c]++);
                        while (at[c] > target[c]) n[c] -= swpm__ends_triangle(x, W, f.restart_index, --at[c]);
                    }
                    if (n[1] - n[0] != SWPM__W(k, 1))
                        return swpm__err("SWPM_WINDOW_STRIP_TRIANGLES", wbase + cols * O * k + 3 * O);
                }
            }
#undef SWPM__W
#undef SWPM__X
#undef SWPM__ICOUNT
        }
#undef SWPM__OFF
#undef SWPM__OFF0
    }
    {
        swpm_result r = swpm__check_drawn(&f);
        if (r.code) return r;
    }
    *file = f;
    return ok;
}

/* ---- vanilla (format.md 3.4, 3.6; 5 step 4: stage 0, (a), (b), (c)) ---- */
static swpm_result swpm__vanilla(swpm_file *f, const uint8_t *bytes, const uint64_t *pe, const uint64_t *pl,
                                 void *scratch, size_t scratch_bytes) {
    swpm_result ok = {NULL, 0, 0, 0, 0};
    const uint32_t W = f->index_width, O = f->offset_width;
    const uint64_t V = f->vertex_count, L = f->lod_count;
    const uint64_t vbase = swpm__u64(bytes + pe[SWPM__VREC] + 8), vlen = pl[SWPM__VREC];
    const uint64_t rbase = swpm__u64(bytes + pe[SWPM__RCNT] + 8), rlen = pl[SWPM__RCNT];
    const uint64_t ibase = swpm__u64(bytes + pe[SWPM__INDX] + 8), ilen = pl[SWPM__INDX];
    const uint64_t lbase = (uint64_t)(f->lods - bytes);
    uint64_t R, M, need, ao, obase, T0, nidx, nrc, r, k, j, sum;
    const uint8_t *rec, *offs, *rc, *x;
#define SWPM__REC(r, c) ((uint64_t)swpm__uw(rec + (4 * (r) + (c)) * O, O))
#define SWPM__OFS(j) ((uint64_t)swpm__uw(offs + (j) * O, O))
#define SWPM__RC(k) ((uint64_t)swpm__uw(rc + (k) * O, O))
#define SWPM__ROW(r, c) (vbase + 8 + O * (4 * (r) + (c)))
    /* stage 0: VREC (length >= 8, R, M, exact length), RCNT a multiple of O, INDX a multiple of 3 W */
    if (vlen < 8) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__VREC] + 16);
    R = swpm__u32(bytes + vbase);
    M = swpm__u32(bytes + vbase + 4);
    need = 4 * (uint64_t)O * R; /* < 2^36: no wrap */
    if (need > vlen - 8) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", vbase + 8);
    ao = 8 + ((need + 3) & ~(uint64_t)3);
    if (ao > vlen || M * O > vlen - ao) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", vbase + ao);
    if (ao + M * O != vlen) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__VREC] + 16);
    if (rlen % O) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__RCNT] + 16);
    if (ilen % W || (ilen / W) % 3) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__INDX] + 16);
    rec = bytes + vbase + 8;
    obase = vbase + ao;
    offs = bytes + obase;
    rc = bytes + rbase;
    x = bytes + ibase;
    nrc = rlen / O;
    nidx = ilen / W;
    T0 = nidx / 3;
    /* (a) the counts of 3.6: change counts sum to M, prev_change_count, RCNT holds L counts, RCNT from 0,
     * non-decreasing, <= R */
    for (sum = 0, r = 0; r < R; r++) sum += SWPM__REC(r, 2); /* R < 2^32 terms < 2^32: no wrap */
    if (sum != M) return swpm__err("SWPM_RECORD_BAD_COUNTS", vbase + 8);
    for (r = 0; r < R; r++)
        if (SWPM__REC(r, 3) != (r ? SWPM__REC(r - 1, 2) : 0)) return swpm__err("SWPM_RECORD_BAD_COUNTS", SWPM__ROW(r, 3));
    if (nrc != L) return swpm__err("SWPM_CHUNK_BAD_LENGTH", rbase);
    for (k = 0; k < L; k++)
        if ((k == 0 && SWPM__RC(0) != 0) || (k > 0 && SWPM__RC(k) < SWPM__RC(k - 1)) || SWPM__RC(k) > R)
            return swpm__err("SWPM_RECORD_BAD_COUNTS", rbase);
    /* INDX < V, R < V, kept < V-1-r, total tris_removed <= T0, change offsets < 3 T0 */
    k = f->indx_partial ? nidx : swpm__first_at_least(x, W, 0, nidx, V, 0, 0); /* (4.2: INDX not all held) */
    if (k < nidx) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", ibase + W * k);
    if (R && R >= V) return swpm__err("SWPM_RECORD_BAD_COUNTS", vbase);
    for (r = 0; r < R; r++)
        if (SWPM__REC(r, 0) + r + 1 >= V) return swpm__err("SWPM_RECORD_BAD_KEPT", SWPM__ROW(r, 0));
    for (sum = 0, r = 0; r < R; r++) sum += SWPM__REC(r, 1);
    if (sum > T0) return swpm__err("SWPM_RECORD_BAD_COUNTS", SWPM__ROW(0, 1));
    for (j = 0; j < M; j++)
        if (SWPM__OFS(j) >= 3 * T0) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", obase + O * j);
    /* (b) LODS against RCNT: vertex_count(k) = V - RCNT[k], then triangle_count(k) = T0 - removed by records
     * [0, RCNT[k]) (RCNT is non-decreasing: one walk) */
    for (k = 0; k < L; k++)
        if (swpm__u32(f->lods + 12 * k) != V - SWPM__RC(k)) return swpm__err("SWPM_LOD_VERTEX_COUNT", lbase + 12 * k);
    for (sum = 0, r = 0, k = 0; k < L; k++) {
        while (r < SWPM__RC(k)) sum += SWPM__REC(r++, 1);
        if (swpm__u32(f->lods + 12 * k + 4) != T0 - sum) return swpm__err("SWPM_RECORD_BAD_COUNTS", lbase + 12 * k);
    }
    /* (c) the replay, stopping at its first problem: a copy of INDX and the number of references each vertex
     * has from live triangles. Record r's slots must hold V-1-r when changed (in the order listed, so a slot
     * listed twice holds kept the second time) and lie in a triangle live after r; then no live triangle
     * may reference V-1-r. (Ranges without all of INDX: it waits for the whole file, 4.2.) */
    if (R && !f->indx_partial) {
        uint8_t *ind;
        uint64_t *refs, pad, live = T0, pos = 0;
        pad = (uint64_t)((8 - ((uintptr_t)scratch & 7)) & 7);
        need = ilen + 8 * V + 7;
        if (scratch == NULL || (uint64_t)scratch_bytes < need) {
            swpm_result s = {SWPM_READER_SCRATCH_TOO_SMALL, 0, 0, 0, 0};
            s.need = need;
            return s;
        }
        refs = (uint64_t *)(void *)((uint8_t *)scratch + pad);
        ind = (uint8_t *)(refs + V);
        memcpy(ind, x, (size_t)ilen); /* (size_t: every length below is within the file or scratch) */
        memset(refs, 0, (size_t)(8 * V));
        for (j = 0; j < nidx; j++) refs[swpm__uw(ind + W * j, W)]++;
        for (r = 0; r < R; r++) {
            uint64_t binned = V - 1 - r, kept = SWPM__REC(r, 0), after = live - SWPM__REC(r, 1);
            uint64_t cc = SWPM__REC(r, 2), s;
            for (j = 0; j < cc; j++) {
                s = SWPM__OFS(pos + j);
                if (s >= 3 * after || swpm__uw(ind + W * s, W) != binned)
                    return swpm__err("SWPM_RECORD_BAD_CHANGE", SWPM__ROW(r, 0));
                swpm__put(ind + W * s, W, kept);
                refs[binned]--;
                refs[kept]++;
            }
            pos += cc;
            for (j = 3 * after; j < 3 * live; j++) refs[swpm__uw(ind + W * j, W)]--;
            live = after;
            if (refs[binned]) return swpm__err("SWPM_PREFIX_VIOLATION", SWPM__ROW(r, 0));
        }
    }
#undef SWPM__REC
#undef SWPM__OFS
#undef SWPM__RC
#undef SWPM__ROW
    f->indx = x;
    f->index_count = nidx;
    f->vrec = rec;
    f->record_count = R;
    f->record_columns = 4;
    f->change_offsets = offs;
    f->change_offset_count = M;
    f->rcnt = rc;
    return ok;
}

/* ---- skip-strip and mixed (format.md 3.7, 3.8; 5 step 4: stage 0, then (a) to (d) or (e)) ---- */
/* 1 if a, b, c make a non-degenerate triangle: three distinct values, none the strips' restart index (3.7) */
SWPM__INLINE uint64_t swpm__tri3(uint64_t a, uint64_t b, uint64_t c, int exempt, uint64_t restart) {
    /* (without branches: strips' values make them unpredictable) */
    return (uint64_t)((a != b) & (b != c) & (a != c) & ((exempt == 0) | ((a != restart) & (b != restart) & (c != restart))));
}
/* The non-degenerate triangles of the m-element list x whose first slot lies in [lo, hi] (strips: every
 * slot starts one, read with a rolling window of three values; lists: every third slot). */
static uint64_t swpm__tris_in(const uint8_t *x, uint32_t W, uint64_t m, uint64_t lo, uint64_t hi, int strip,
                              int exempt, uint64_t restart) {
    uint64_t t, n = 0, a, b, c;
    if (m < 3) return 0;
    if (hi > m - 3) hi = m - 3;
    if (lo > hi) return 0;
    if (!strip) {
        for (t = lo; t <= hi; t += 3)
            n += swpm__tri3(swpm__uw(x + t * W, W), swpm__uw(x + (t + 1) * W, W), swpm__uw(x + (t + 2) * W, W),
                            exempt, restart);
        return n;
    }
    a = swpm__uw(x + lo * W, W);
    b = swpm__uw(x + (lo + 1) * W, W);
    for (t = lo; t <= hi; t++, a = b, b = c) {
        c = swpm__uw(x + (t + 2) * W, W);
        n += swpm__tri3(a, b, c, exempt, restart);
    }
    return n;
}

static swpm_result swpm__levels(swpm_file *f, const uint8_t *bytes, const uint64_t *pe, const uint64_t *pl,
                                void *scratch, size_t scratch_bytes) {
    swpm_result ok = {NULL, 0, 0, 0, 0};
    const int mixed = f->encoding == 4;
    const int rk = mixed ? SWPM__MREC : SWPM__SREC, lk = mixed ? SWPM__MLVL : SWPM__SKIP;
    const uint32_t W = f->index_width, O = f->offset_width, cols = mixed ? 5 : 4;
    const uint64_t V = f->vertex_count, L = f->lod_count;
    const uint64_t vbase = swpm__u64(bytes + pe[rk] + 8), vlen = pl[rk];
    const uint64_t rbase = swpm__u64(bytes + pe[SWPM__RCNT] + 8), rlen = pl[SWPM__RCNT];
    const uint64_t ibase = swpm__u64(bytes + pe[SWPM__INDX] + 8), ilen = pl[SWPM__INDX];
    const uint64_t sbase = swpm__u64(bytes + pe[lk] + 8), slen = pl[lk];
    const uint64_t lbase = (uint64_t)(f->lods - bytes);
    const int exempt = f->has_restart, strip = f->primitive_strip;
    const uint64_t restart = f->restart_index;
    uint64_t R, M, need, ao, obase, nidx, n, C, at[6], size[6], pos, r, k, j, l, sum, row0, narr, longest = 0;
    const uint8_t *rec, *offs, *rc, *x, *a0, *a1, *a2, *a3, *list1, *list2;
#define SWPM__REC(r, c) ((uint64_t)swpm__uw(rec + (cols * (r) + (c)) * O, O))
#define SWPM__OFS(j) ((uint64_t)swpm__uw(offs + (j) * O, O))
#define SWPM__RC(k) ((uint64_t)swpm__uw(rc + (k) * O, O))
#define SWPM__ROW(r, c) (row0 + O * (cols * (r) + (c)))
#define SWPM__A(a, i) ((uint64_t)swpm__uw((a) + (i) * O, O))
#define SWPM__I(a, i) ((uint64_t)swpm__uw((a) + (i) * W, W))
#define SWPM__VC(k) ((uint64_t)swpm__u32(f->lods + 12 * (k)))
#define SWPM__TC(k) ((uint64_t)swpm__u32(f->lods + 12 * (k) + 4))
    /* stage 0: the record chunk (length >= 8, R, M, exact length), RCNT a multiple of O, INDX of W, then
     * SKIP / MLVL: length >= 8, each array against the bytes that remain, exact length */
    if (vlen < 8) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[rk] + 16);
    R = swpm__u32(bytes + vbase);
    M = swpm__u32(bytes + vbase + 4);
    need = (uint64_t)cols * O * R; /* < 2^37: no wrap */
    if (need > vlen - 8) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", vbase + 8);
    ao = 8 + ((need + 3) & ~(uint64_t)3);
    if (ao > vlen || M * O > vlen - ao) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", vbase + ao);
    if (ao + M * O != vlen) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[rk] + 16);
    if (rlen % O) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__RCNT] + 16);
    if (ilen % W) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[SWPM__INDX] + 16);
    if (slen < 8) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[lk] + 16);
    n = swpm__u32(bytes + sbase);
    C = swpm__u32(bytes + sbase + 4); /* C, mixed D */
    size[0] = O * n;
    size[1] = size[2] = size[3] = O * (n + 1);
    size[4] = size[5] = W * C;
    narr = mixed ? 6 : 5;
    for (pos = 8, j = 0; j < narr; j++) {
        if (pos > slen || size[j] > slen - pos) return swpm__err("SWPM_COUNT_EXCEEDS_CHUNK", sbase + pos);
        at[j] = sbase + pos;
        pos += j + 1 == narr ? size[j] : (size[j] + 3) & ~(uint64_t)3;
    }
    if (pos != slen) return swpm__err("SWPM_CHUNK_BAD_LENGTH", pe[lk] + 16);
    row0 = vbase + 8;
    rec = bytes + row0;
    obase = vbase + ao;
    offs = bytes + obase;
    rc = bytes + rbase;
    x = bytes + ibase;
    nidx = ilen / W;
    a0 = bytes + at[0];
    a1 = bytes + at[1];
    a2 = bytes + at[2];
    a3 = bytes + at[3];
    list1 = bytes + at[4];
    list2 = mixed ? bytes + at[5] : NULL;
    /* (a) the counts of 3.6: change counts sum to M, prev_change_count, RCNT holds L counts, from 0,
     * non-decreasing, <= R */
    for (sum = 0, r = 0; r < R; r++) sum += SWPM__REC(r, cols - 2);
    if (sum != M) return swpm__err("SWPM_RECORD_BAD_COUNTS", row0);
    for (r = 0; r < R; r++)
        if (SWPM__REC(r, cols - 1) != (r ? SWPM__REC(r - 1, cols - 2) : 0))
            return swpm__err("SWPM_RECORD_BAD_COUNTS", SWPM__ROW(r, cols - 1));
    if (rlen / O != L) return swpm__err("SWPM_CHUNK_BAD_LENGTH", rbase);
    for (k = 0; k < L; k++)
        if ((k == 0 && SWPM__RC(0) != 0) || (k > 0 && SWPM__RC(k) < SWPM__RC(k - 1)) || SWPM__RC(k) > R)
            return swpm__err("SWPM_RECORD_BAD_COUNTS", rbase);
    if (!mixed) {
        /* (a) the strips' restart index below V (ends the checks), then the level table by itself */
        int bad = 0;
        if (exempt && restart < V) return swpm__err("SWPM_META_BAD_FIELD", swpm__u64(bytes + pe[SWPM__META] + 8));
        {
            const uint8_t *arr[3];
            uint64_t total[3], q;
            arr[0] = a1, arr[1] = a2, arr[2] = a3;
            total[0] = nidx, total[1] = C, total[2] = R;
            for (q = 0; q < 3; q++) {
                if (SWPM__A(arr[q], 0) != 0 || SWPM__A(arr[q], n) != total[q]) bad = 1;
                for (l = 0; l < n; l++)
                    if (SWPM__A(arr[q], l + 1) < SWPM__A(arr[q], l)) bad = 1;
            }
        }
        for (l = 0; !bad && l <= n; l++)
            if (SWPM__A(a2, l) != SWPM__A(a1, l)) bad = 1;
        for (l = 0; !bad && !strip && l < n; l++)
            if ((SWPM__A(a1, l + 1) - SWPM__A(a1, l)) % 3) bad = 1;
        if (n == 0 || SWPM__A(a0, 0) != 0 || SWPM__A(a0, n - 1) >= L) bad = 1;
        for (l = 1; l < n; l++)
            if (SWPM__A(a0, l) <= SWPM__A(a0, l - 1)) bad = 1;
        if (bad) return swpm__err("SWPM_LEVEL_BAD_TABLE", sbase);
        /* values < V: INDX, level_collapsed_indices (the restart index exempt), kept and binned */
        k = f->indx_partial ? nidx : swpm__first_at_least(x, W, 0, nidx, V, exempt, restart);
        if (k < nidx) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", ibase + W * k);
        k = swpm__first_at_least(list1, W, 0, C, V, exempt, restart);
        if (k < C) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", at[4] + W * k);
        for (r = 0; r < R; r++)
            if (SWPM__REC(r, 0) >= V) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", SWPM__ROW(r, 0));
        for (r = 0; r < R; r++)
            if (SWPM__REC(r, 1) >= V) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", SWPM__ROW(r, 1));
    } else {
        /* (a) the level table: the start arrays (the last bad one's start), level_first_lod (its start),
         * else level_record_start against RCNT (that element) */
        uint64_t where = 0, q;
        const uint8_t *arr[3];
        uint64_t total[3], step[3];
        arr[0] = a1, arr[1] = a2, arr[2] = a3;
        total[0] = nidx, total[1] = C, total[2] = R;
        step[0] = step[1] = 3, step[2] = 1;
        for (q = 0; q < 3; q++) {
            int bad = SWPM__A(arr[q], 0) != 0 || SWPM__A(arr[q], n) != total[q];
            for (l = 0; l < n; l++)
                if (SWPM__A(arr[q], l + 1) < SWPM__A(arr[q], l) || (SWPM__A(arr[q], l + 1) - SWPM__A(arr[q], l)) % step[q])
                    bad = 1;
            if (bad) where = at[q + 1];
        }
        {
            int bad = n == 0 || SWPM__A(a0, 0) != 0 || SWPM__A(a0, n - 1) >= L;
            for (l = 1; l < n; l++)
                if (SWPM__A(a0, l) <= SWPM__A(a0, l - 1)) bad = 1;
            if (bad) where = at[0];
            else if (!where)
                for (l = 0; l < n; l++)
                    if (SWPM__RC(SWPM__A(a0, l)) != SWPM__A(a3, l)) {
                        where = at[3] + O * l;
                        break;
                    }
        }
        if (where) return swpm__err("SWPM_MIXED_BAD_LEVELS", where);
        /* values < V (INDX, both dynamic arrays), R < V, kept < V-1-r */
        k = f->indx_partial ? nidx : swpm__first_at_least(x, W, 0, nidx, V, 0, 0);
        if (k < nidx) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", ibase + W * k);
        k = swpm__first_at_least(list1, W, 0, C, V, 0, 0);
        if (k < C) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", at[4] + W * k);
        k = swpm__first_at_least(list2, W, 0, C, V, 0, 0);
        if (k < C) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", at[5] + W * k);
        if (R && R >= V) return swpm__err("SWPM_RECORD_BAD_COUNTS", vbase);
        for (r = 0; r < R; r++)
            if (SWPM__REC(r, 0) + r + 1 >= V) return swpm__err("SWPM_RECORD_BAD_KEPT", SWPM__ROW(r, 0));
    }
    /* change offsets inside the list of their record's level (skip-strip: its list; mixed: its dynamic list;
     * level l holds records [level_record_start[l], level_record_start[l+1])) */
    for (pos = 0, l = 0, r = 0; r < R; r++) {
        uint64_t cc = SWPM__REC(r, cols - 2), limit;
        while (SWPM__A(a3, l + 1) <= r) l++; /* level_record_start[n] = R > r stops it */
        limit = SWPM__A(mixed ? a2 : a1, l + 1) - SWPM__A(mixed ? a2 : a1, l);
        for (j = 0; j < cc; j++, pos++)
            if (SWPM__OFS(pos) >= limit) return swpm__err("SWPM_INDEX_OUT_OF_RANGE", obase + O * pos);
    }
    if (!mixed) {
        uint64_t badk = L, cat = at[4];
        uint8_t *buf;
        /* (a) prefix: level l's list uses only vertices < vertex_count(level_first_lod[l]) */
        for (l = 0; !f->indx_partial && l < n; l++) {
            uint64_t e = SWPM__A(a1, l + 1);
            k = swpm__first_at_least(x, W, SWPM__A(a1, l), e, SWPM__VC(SWPM__A(a0, l)), exempt, restart);
            if (k < e) return swpm__err("SWPM_PREFIX_VIOLATION", ibase + W * k);
        }
        /* (c) R < V, binned = V-1-r, kept < V-1-r, the level table against RCNT, LODS vertex counts */
        if (R && R >= V) return swpm__err("SWPM_RECORD_BAD_COUNTS", vbase);
        for (r = 0; r < R; r++)
            if (SWPM__REC(r, 1) != V - 1 - r) return swpm__err("SWPM_RECORD_BAD_BINNED", SWPM__ROW(r, 1));
        for (r = 0; r < R; r++)
            if (SWPM__REC(r, 0) + r + 1 >= V) return swpm__err("SWPM_RECORD_BAD_KEPT", SWPM__ROW(r, 0));
        for (l = 0; l < n; l++)
            if (SWPM__RC(SWPM__A(a0, l)) != SWPM__A(a3, l)) return swpm__err("SWPM_LEVEL_BAD_TABLE", sbase);
        for (k = 0; k < L; k++)
            if (SWPM__VC(k) != V - SWPM__RC(k)) return swpm__err("SWPM_LOD_VERTEX_COUNT", lbase + 12 * k);
        /* (d) the replay of each level's records on a copy of its list (scratch: the longest list of a level
         * with records), which must give its collapsed list; LODS triangle counts are counted on the way
         * (the non-degenerate triangles after RCNT[k] records, updated around each changed slot) and their
         * first mismatch reported last, stage (e) */
        for (l = 0; l < n; l++)
            if (SWPM__A(a3, l + 1) > SWPM__A(a3, l) && SWPM__A(a1, l + 1) - SWPM__A(a1, l) > longest)
                longest = SWPM__A(a1, l + 1) - SWPM__A(a1, l);
        need = f->indx_partial ? 0 : W * longest; /* (4.2: INDX not all held, the replay waits) */
        if (need && (scratch == NULL || (uint64_t)scratch_bytes < need)) {
            swpm_result s = {SWPM_READER_SCRATCH_TOO_SMALL, 0, 0, 0, 0};
            s.need = need;
            return s;
        }
        buf = (uint8_t *)scratch;
        for (pos = 0, k = 0, l = 0; !f->indx_partial && l < n; l++) {
            uint64_t s0 = SWPM__A(a1, l), m = SWPM__A(a1, l + 1) - s0, r0 = SWPM__A(a3, l), r1 = SWPM__A(a3, l + 1);
            uint64_t kend = l + 1 < n ? SWPM__A(a0, l + 1) : L, count;
            const uint8_t *cur = x + W * s0;
            if (r1 > r0 && m) { /* (an empty list needs no copy: scratch may be NULL then) */
                memcpy(buf, cur, (size_t)(W * m));
                cur = buf;
            }
            count = swpm__tris_in(cur, W, m, 0, m, strip, exempt, restart);
            for (; k < kend && SWPM__RC(k) == r0; k++)
                if (badk == L && SWPM__TC(k) != count) badk = k;
            for (r = r0; r < r1; r++) {
                uint64_t cc = SWPM__REC(r, 2), kept = SWPM__REC(r, 0), s, lo;
                for (j = 0; j < cc; j++) {
                    s = SWPM__OFS(pos + j);
                    if (SWPM__I(buf, s) != V - 1 - r) return swpm__err("SWPM_RECORD_BAD_CHANGE", SWPM__ROW(r, 0));
                    lo = strip ? (s >= 2 ? s - 2 : 0) : s - s % 3;
                    count -= swpm__tris_in(buf, W, m, lo, strip ? s : lo, strip, exempt, restart);
                    swpm__put(buf + W * s, W, kept);
                    count += swpm__tris_in(buf, W, m, lo, strip ? s : lo, strip, exempt, restart);
                }
                pos += cc;
                for (; k < kend && SWPM__RC(k) == r + 1; k++)
                    if (badk == L && SWPM__TC(k) != count) badk = k;
            }
            for (j = 0; j < m; j++)
                if (SWPM__I(list1, s0 + j) != SWPM__I(cur, j)) return swpm__err("SWPM_LEVEL_BAD_TABLE", cat + W * (s0 + j));
        }
        /* the collapsed lists' prefix: level l's uses only vertices < V - level_record_start[l+1] */
        for (l = 0; !f->indx_partial && l < n; l++) {
            uint64_t e = SWPM__A(a2, l + 1);
            k = swpm__first_at_least(list1, W, SWPM__A(a2, l), e, V - SWPM__A(a3, l + 1), exempt, restart);
            if (k < e) return swpm__err("SWPM_PREFIX_VIOLATION", cat + W * k);
        }
        if (badk < L) return swpm__err("SWPM_RECORD_BAD_COUNTS", lbase + 12 * badk);
        for (l = 0; l < n; l++)
            if (SWPM__A(a1, l + 1) - SWPM__A(a1, l) > longest) longest = SWPM__A(a1, l + 1) - SWPM__A(a1, l);
    } else {
        uint64_t q, cs, cr, rs, rr, s0, d0, nd, ns;
        /* (b) per-level removals: a level's records remove at most its static, then dynamic, triangles */
        for (q = 0; q < 2; q++)
            for (l = 0; l < n; l++) {
                const uint8_t *st = q ? a2 : a1;
                for (sum = 0, r = SWPM__A(a3, l); r < SWPM__A(a3, l + 1); r++) sum += SWPM__REC(r, 1 + q);
                if (sum > (SWPM__A(st, l + 1) - SWPM__A(st, l)) / 3)
                    return swpm__err("SWPM_RECORD_BAD_COUNTS", row0 + O * (1 + q));
            }
        /* (c) LODS vertex counts, then triangle counts: the live triangles of both lists of k's level after
         * RCNT[k] records (two running sums of removals: to RCNT[k] and to the level's first record) */
        for (k = 0; k < L; k++)
            if (SWPM__VC(k) != V - SWPM__RC(k)) return swpm__err("SWPM_LOD_VERTEX_COUNT", lbase + 12 * k);
        for (cs = cr = rs = rr = 0, l = 0, k = 0; k < L; k++) {
            uint64_t live;
            while (l + 1 < n && SWPM__A(a0, l + 1) <= k) l++;
            for (; cr < SWPM__RC(k); cr++) cs += SWPM__REC(cr, 1) + SWPM__REC(cr, 2);
            for (; rr < SWPM__A(a3, l); rr++) rs += SWPM__REC(rr, 1) + SWPM__REC(rr, 2);
            live = (SWPM__A(a1, l + 1) - SWPM__A(a1, l)) / 3 + (SWPM__A(a2, l + 1) - SWPM__A(a2, l)) / 3 - (cs - rs);
            if (SWPM__TC(k) != live) return swpm__err("SWPM_RECORD_BAD_COUNTS", lbase + 12 * k);
        }
        /* the prefix checks: static lists, dynamic lists (vertices < vertex_count(level_first_lod[l])), the
         * live part of the collapsed dynamic lists (< V - level_record_start[l+1]) */
        for (q = f->indx_partial ? 1 : 0; q < 2; q++) /* (4.2: INDX's static lists not all held: they wait) */
            for (l = 0; l < n; l++) {
                const uint8_t *st = q ? a2 : a1;
                uint64_t e = SWPM__A(st, l + 1);
                k = swpm__first_at_least(q ? list1 : x, W, SWPM__A(st, l), e, SWPM__VC(SWPM__A(a0, l)), 0, 0);
                if (k < e) return swpm__err("SWPM_PREFIX_VIOLATION", (q ? at[4] : ibase) + W * k);
            }
        for (l = 0; l < n; l++) {
            uint64_t e;
            for (sum = 0, r = SWPM__A(a3, l); r < SWPM__A(a3, l + 1); r++) sum += SWPM__REC(r, 2);
            d0 = SWPM__A(a2, l);
            e = d0 + 3 * ((SWPM__A(a2, l + 1) - d0) / 3 - sum);
            k = swpm__first_at_least(list2, W, d0, e, V - SWPM__A(a3, l + 1), 0, 0);
            if (k < e) return swpm__err("SWPM_PREFIX_VIOLATION", at[5] + W * k);
        }
        /* (d) the replay (3.8), as vanilla's per level: a copy of the level's dynamic list and a count of the
         * live references to each vertex from both lists (scratch: 8 V + the longest dynamic list of a level
         * with records + 7 alignment bytes); then the copy must equal the collapsed dynamic list */
        for (l = 0; l < n; l++)
            if (SWPM__A(a2, l + 1) - SWPM__A(a2, l) > longest) longest = SWPM__A(a2, l + 1) - SWPM__A(a2, l);
        if (f->indx_partial) {
            /* (4.2: the replay reads the static lists of INDX, not all held: it waits for the whole file, and
             * so does its first step without records, the dynamic lists against their collapsed lists) */
        } else if (R) {
            uint64_t *refs, pad = (uint64_t)((8 - ((uintptr_t)scratch & 7)) & 7), dl = 0;
            uint8_t *buf;
            for (l = 0; l < n; l++)
                if (SWPM__A(a3, l + 1) > SWPM__A(a3, l) && SWPM__A(a2, l + 1) - SWPM__A(a2, l) > dl)
                    dl = SWPM__A(a2, l + 1) - SWPM__A(a2, l);
            need = 8 * V + W * dl + 7;
            if (scratch == NULL || (uint64_t)scratch_bytes < need) {
                swpm_result s = {SWPM_READER_SCRATCH_TOO_SMALL, 0, 0, 0, 0};
                s.need = need;
                return s;
            }
            refs = (uint64_t *)(void *)((uint8_t *)scratch + pad);
            buf = (uint8_t *)(refs + V);
            memset(refs, 0, (size_t)(8 * V));
            for (pos = 0, l = 0; l < n; l++) {
                uint64_t r0 = SWPM__A(a3, l), r1 = SWPM__A(a3, l + 1), m;
                s0 = SWPM__A(a1, l);
                d0 = SWPM__A(a2, l);
                m = SWPM__A(a2, l + 1) - d0;
                ns = (SWPM__A(a1, l + 1) - s0) / 3;
                nd = m / 3;
                if (r1 == r0) { /* no record: the collapsed list is the list */
                    for (j = 0; j < m; j++)
                        if (SWPM__I(list1, d0 + j) != SWPM__I(list2, d0 + j))
                            return swpm__err("SWPM_MIXED_BAD_LEVELS", at[5] + W * (d0 + j));
                    continue;
                }
                memcpy(buf, list1 + W * d0, (size_t)(W * m));
                for (j = 0; j < m; j++) refs[SWPM__I(buf, j)]++;
                for (j = 0; j < 3 * ns; j++) refs[SWPM__I(x, s0 + j)]++;
                for (r = r0; r < r1; r++) {
                    uint64_t b = V - 1 - r, kept = SWPM__REC(r, 0), cc = SWPM__REC(r, 3);
                    uint64_t as = ns - SWPM__REC(r, 1), ad = nd - SWPM__REC(r, 2), s;
                    for (j = 0; j < cc; j++) {
                        s = SWPM__OFS(pos + j);
                        if (s >= 3 * ad || SWPM__I(buf, s) != b) return swpm__err("SWPM_RECORD_BAD_CHANGE", SWPM__ROW(r, 0));
                        swpm__put(buf + W * s, W, kept);
                        refs[b]--;
                        refs[kept]++;
                    }
                    pos += cc;
                    for (j = 3 * ad; j < 3 * nd; j++) refs[SWPM__I(buf, j)]--;
                    for (j = 3 * as; j < 3 * ns; j++) refs[SWPM__I(x, s0 + j)]--;
                    ns = as;
                    nd = ad;
                    if (refs[b]) return swpm__err("SWPM_PREFIX_VIOLATION", SWPM__ROW(r, 0));
                }
                for (j = 0; j < m; j++)
                    if (SWPM__I(list2, d0 + j) != SWPM__I(buf, j))
                        return swpm__err("SWPM_MIXED_BAD_LEVELS", at[5] + W * (d0 + j));
                for (j = 0; j < 3 * nd; j++) refs[SWPM__I(buf, j)]--; /* forget the level's references */
                for (j = 0; j < 3 * ns; j++) refs[SWPM__I(x, s0 + j)]--;
            }
        } else {
            for (j = 0; j < C; j++)
                if (SWPM__I(list1, j) != SWPM__I(list2, j)) return swpm__err("SWPM_MIXED_BAD_LEVELS", at[5] + W * j);
        }
    }
#undef SWPM__REC
#undef SWPM__OFS
#undef SWPM__RC
#undef SWPM__ROW
#undef SWPM__A
#undef SWPM__I
#undef SWPM__VC
#undef SWPM__TC
    f->indx = x;
    f->index_count = nidx;
    f->vrec = rec;
    f->record_count = R;
    f->record_columns = cols;
    f->change_offsets = offs;
    f->change_offset_count = M;
    f->rcnt = rc;
    f->level_count = n;
    f->level_arrays[0] = a0;
    f->level_arrays[1] = a1;
    f->level_arrays[2] = a2;
    f->level_arrays[3] = a3;
    f->level_lists[0] = list1;
    f->level_lists[1] = list2;
    f->level_list_count = C;
    f->longest_list = longest;
    return ok;
}

/* ---- accessors ---- */
int swpm_encoding(const swpm_file *f) { return f->encoding; }
const uint8_t *swpm_collapse_records(const swpm_file *f, uint64_t *count, uint32_t *row_bytes) {
    *count = f->record_count;
    *row_bytes = f->record_columns * f->offset_width;
    return f->vrec;
}
void swpm_collapse_record(const swpm_file *f, uint64_t r, uint32_t *kept, uint32_t *tris_removed,
                          uint32_t *change_count, uint32_t *prev_change_count) {
    uint32_t O = f->offset_width;
    const uint8_t *p = f->vrec + 4 * (uint64_t)O * r;
    *kept = swpm__uw(p, O);
    *tris_removed = swpm__uw(p + O, O);
    *change_count = swpm__uw(p + 2 * O, O);
    *prev_change_count = swpm__uw(p + 3 * O, O);
}
const uint8_t *swpm_collapse_change_offsets(const swpm_file *f, uint64_t *count) {
    *count = f->change_offset_count;
    return f->change_offsets;
}
const uint8_t *swpm_lod_record_counts(const swpm_file *f, uint64_t *count) {
    *count = f->encoding != 2 ? f->lod_count : 0;
    return f->rcnt;
}
uint32_t swpm_lod_record_count(const swpm_file *f, uint64_t k) {
    return f->encoding != 2 ? swpm__uw(f->rcnt + k * f->offset_width, f->offset_width) : 0;
}
/* Widen a dirty range [*first, *end) (empty when *first >= *end) to hold [a, b): O(1) a write. */
static void swpm__dirty(uint64_t *first, uint64_t *end, uint64_t a, uint64_t b) {
    if (*first >= *end) {
        *first = a;
        *end = b;
    } else {
        if (a < *first) *first = a;
        if (b > *end) *end = b;
    }
}
static int swpm__take_dirty(uint64_t *df, uint64_t *de, uint64_t *first, uint64_t *end) {
    int any = *df < *de;
    *first = any ? *df : 0;
    *end = any ? *de : 0;
    *df = *de = 0;
    return any;
}
int swpm_vanilla_take_dirty(swpm_vanilla_instance *inst, uint64_t *first, uint64_t *end) {
    return swpm__take_dirty(&inst->dirty_first, &inst->dirty_end, first, end);
}
int swpm_level_take_dirty(swpm_level_instance *inst, uint64_t *first, uint64_t *end) {
    return swpm__take_dirty(&inst->dirty_first, &inst->dirty_end, first, end);
}
int swpm_vanilla_instance_init(const swpm_file *f, swpm_vanilla_instance *inst, void *buffer, uint64_t capacity) {
    uint64_t n = f->index_count * f->index_width;
    if (f->encoding != 1 || capacity < n || (n && buffer == NULL)) return 0;
    if (n) memcpy(buffer, f->indx, (size_t)n); /* n <= the file length, a size_t */
    inst->indices = (uint8_t *)buffer;
    inst->lod = 0;
    inst->applied = 0; /* RCNT[0] = 0 (validated) */
    inst->change_pos = 0;
    inst->live = f->index_count / 3;
    inst->dirty_first = 0; /* the whole copy is new to the GPU */
    inst->dirty_end = f->index_count;
    return 1;
}
uint64_t swpm_vanilla_set_lod(const swpm_file *f, swpm_vanilla_instance *inst, uint64_t lod,
                              uint32_t *vertex_count) {
    uint32_t W = f->index_width, O = f->offset_width, kept, removed, cc, prev;
    uint64_t target, j;
    if (lod >= f->lod_count) lod = f->lod_count - 1;
    target = swpm_lod_record_count(f, lod);
    while (inst->applied < target) { /* apply record `applied`: its slots take kept */
        swpm_collapse_record(f, inst->applied, &kept, &removed, &cc, &prev);
        for (j = 0; j < cc; j++) {
            uint64_t s = swpm__uw(f->change_offsets + O * (inst->change_pos + j), O);
            swpm__put(inst->indices + W * s, W, kept);
            swpm__dirty(&inst->dirty_first, &inst->dirty_end, s, s + 1);
        }
        inst->change_pos += cc;
        inst->live -= removed;
        inst->applied++;
    }
    while (inst->applied > target) { /* undo the last applied record r: its slots hold V-1-r again */
        uint64_t r = --inst->applied;
        swpm_collapse_record(f, r, &kept, &removed, &cc, &prev);
        inst->change_pos -= cc;
        for (j = 0; j < cc; j++) {
            uint64_t s = swpm__uw(f->change_offsets + O * (inst->change_pos + j), O);
            swpm__put(inst->indices + W * s, W, (uint64_t)f->vertex_count - 1 - r);
            swpm__dirty(&inst->dirty_first, &inst->dirty_end, s, s + 1);
        }
        inst->live += removed;
    }
    inst->lod = lod;
    *vertex_count = swpm_lod_vertex_count(f, lod);
    return 3 * inst->live;
}

/* ---- skip-strip and mixed accessors and instances (format.md 3.7, 3.8) ---- */
int swpm_primitive_strip(const swpm_file *f) { return f->strips || (f->encoding == 3 && f->primitive_strip); }
uint64_t swpm_level_count(const swpm_file *f) { return f->level_count; }
const uint8_t *swpm_level_array(const swpm_file *f, int which, uint64_t *count, uint32_t *width) {
    *count = 0;
    *width = which >= 4 ? f->index_width : f->offset_width;
    if (f->encoding != 3 && f->encoding != 4) return NULL;
    if (which == 0) *count = f->level_count;
    else if (which >= 1 && which <= 3) *count = f->level_count + 1;
    else if (which == 4 || (which == 5 && f->encoding == 4)) *count = f->level_list_count;
    else return NULL;
    return which < 4 ? f->level_arrays[which] : f->level_lists[which - 4];
}
static uint64_t swpm__la(const swpm_file *f, int which, uint64_t i) {
    return swpm__uw(f->level_arrays[which] + i * f->offset_width, f->offset_width);
}
uint64_t swpm_level_of_lod(const swpm_file *f, uint64_t lod) {
    uint64_t lo = 0, hi = f->level_count; /* the last level whose first LOD is <= lod */
    if (hi == 0) return 0;
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (swpm__la(f, 0, mid) <= lod) lo = mid;
        else hi = mid;
    }
    return lo;
}
int swpm_level_at(const swpm_file *f, uint64_t l, swpm_level *out) {
    if ((f->encoding != 3 && f->encoding != 4) || l >= f->level_count) return 0;
    out->first_lod = swpm__la(f, 0, l);
    out->lod_end = l + 1 < f->level_count ? swpm__la(f, 0, l + 1) : f->lod_count;
    out->record_start = swpm__la(f, 3, l);
    out->record_end = swpm__la(f, 3, l + 1);
    out->index_start = swpm__la(f, 1, l);
    out->index_count = swpm__la(f, 1, l + 1) - out->index_start;
    out->dynamic_start = f->encoding == 4 ? swpm__la(f, 2, l) : 0;
    out->dynamic_count = f->encoding == 4 ? swpm__la(f, 2, l + 1) - out->dynamic_start : 0;
    return 1;
}
uint32_t swpm_collapse_field(const swpm_file *f, uint64_t r, uint32_t column) {
    return swpm__uw(f->vrec + ((uint64_t)f->record_columns * r + column) * f->offset_width, f->offset_width);
}
uint64_t swpm_level_instance_bytes(const swpm_file *f) {
    return (f->encoding == 3 || f->encoding == 4) ? f->longest_list * f->index_width : 0;
}
/* Copy level l's stored list (skip-strip: its INDX range, or its range of level_collapsed_indices; mixed: its
 * dynamic list or its collapsed one) into the buffer; the instance then stands at the level's first record
 * or after its last. */
static void swpm__level_load(const swpm_file *f, swpm_level_instance *inst, uint64_t l, int collapsed) {
    const int mixed = f->encoding == 4;
    const uint32_t W = f->index_width, cols = f->record_columns;
    uint64_t s0 = swpm__la(f, mixed ? 2 : 1, l), m = swpm__la(f, mixed ? 2 : 1, l + 1) - s0;
    uint64_t r0 = swpm__la(f, 3, l), r1 = swpm__la(f, 3, l + 1), r = collapsed ? r1 : r0, q;
    const uint8_t *src = collapsed ? f->level_lists[mixed ? 1 : 0] : mixed ? f->level_lists[0] : f->indx;
    if (m) memcpy(inst->indices, src + W * s0, (size_t)(W * m));
    if (m) swpm__dirty(&inst->dirty_first, &inst->dirty_end, 0, m);
    /* the change offsets' position of record r: walk from where the instance stands */
    for (q = inst->applied; q < r; q++) inst->change_pos += swpm_collapse_field(f, q, cols - 2);
    for (q = inst->applied; q > r; q--) inst->change_pos -= swpm_collapse_field(f, q - 1, cols - 2);
    inst->level = l;
    inst->count = m;
    inst->applied = r;
    if (mixed) {
        inst->static_live = (swpm__la(f, 1, l + 1) - swpm__la(f, 1, l)) / 3;
        inst->dynamic_live = m / 3;
        for (q = r0; collapsed && q < r1; q++) {
            inst->static_live -= swpm_collapse_field(f, q, 1);
            inst->dynamic_live -= swpm_collapse_field(f, q, 2);
        }
    }
}
static int swpm__level_init(const swpm_file *f, int enc, swpm_level_instance *inst, void *buffer,
                            uint64_t capacity) {
    uint64_t need = swpm_level_instance_bytes(f);
    if (f->encoding != enc || capacity < need || (need && buffer == NULL)) return 0;
    inst->indices = (uint8_t *)buffer;
    inst->lod = 0;
    inst->applied = 0;
    inst->change_pos = 0;
    inst->dirty_first = inst->dirty_end = 0;
    swpm__level_load(f, inst, 0, 0);
    return 1;
}
int swpm_skip_instance_init(const swpm_file *f, swpm_level_instance *inst, void *buffer, uint64_t capacity) {
    return swpm__level_init(f, 3, inst, buffer, capacity);
}
int swpm_mixed_instance_init(const swpm_file *f, swpm_level_instance *inst, void *buffer, uint64_t capacity) {
    return swpm__level_init(f, 4, inst, buffer, capacity);
}
/* Move to LOD lod: load its level's nearer stored list when the level changes, then apply or undo records
 * up to RCNT[lod] (3.7: a record sets its slots to kept; undoing sets them back to V-1-r). */
static void swpm__level_move(const swpm_file *f, swpm_level_instance *inst, uint64_t lod) {
    const uint32_t W = f->index_width, O = f->offset_width, cols = f->record_columns;
    const int mixed = f->encoding == 4;
    uint64_t target, l, j;
    if (lod >= f->lod_count) lod = f->lod_count - 1;
    target = swpm_lod_record_count(f, lod);
    l = swpm_level_of_lod(f, lod);
    if (l != inst->level) {
        uint64_t r0 = swpm__la(f, 3, l), r1 = swpm__la(f, 3, l + 1);
        swpm__level_load(f, inst, l, r1 - target < target - r0);
    }
    while (inst->applied < target) {
        uint64_t r = inst->applied, cc = swpm_collapse_field(f, r, cols - 2), kept = swpm_collapse_field(f, r, 0);
        for (j = 0; j < cc; j++) {
            uint64_t s = swpm__uw(f->change_offsets + O * (inst->change_pos + j), O);
            swpm__put(inst->indices + W * s, W, kept);
            swpm__dirty(&inst->dirty_first, &inst->dirty_end, s, s + 1);
        }
        inst->change_pos += cc;
        if (mixed) {
            inst->static_live -= swpm_collapse_field(f, r, 1);
            inst->dynamic_live -= swpm_collapse_field(f, r, 2);
        }
        inst->applied++;
    }
    while (inst->applied > target) {
        uint64_t r = --inst->applied, cc = swpm_collapse_field(f, r, cols - 2);
        inst->change_pos -= cc;
        for (j = 0; j < cc; j++) {
            uint64_t s = swpm__uw(f->change_offsets + O * (inst->change_pos + j), O);
            swpm__put(inst->indices + W * s, W, (uint64_t)f->vertex_count - 1 - r);
            swpm__dirty(&inst->dirty_first, &inst->dirty_end, s, s + 1);
        }
        if (mixed) {
            inst->static_live += swpm_collapse_field(f, r, 1);
            inst->dynamic_live += swpm_collapse_field(f, r, 2);
        }
    }
    inst->lod = lod;
}
uint64_t swpm_skip_set_lod(const swpm_file *f, swpm_level_instance *inst, uint64_t lod, uint32_t *vertex_count) {
    swpm__level_move(f, inst, lod);
    *vertex_count = swpm_lod_vertex_count(f, inst->lod);
    return inst->count;
}
uint64_t swpm_mixed_set_lod(const swpm_file *f, swpm_level_instance *inst, uint64_t lod, uint64_t *static_first,
                            uint64_t *static_count, uint32_t *vertex_count) {
    swpm__level_move(f, inst, lod);
    *static_first = swpm__la(f, 1, inst->level);
    *static_count = 3 * inst->static_live;
    *vertex_count = swpm_lod_vertex_count(f, inst->lod);
    return 3 * inst->dynamic_live;
}

uint32_t swpm_features(const swpm_file *f) { return f->features; }
uint32_t swpm_index_width(const swpm_file *f) { return f->index_width; }
uint32_t swpm_offset_width(const swpm_file *f) { return f->offset_width; }
uint32_t swpm_vertex_count(const swpm_file *f) { return f->vertex_count; }
uint64_t swpm_lod_count(const swpm_file *f) { return f->lod_count; }
const uint8_t *swpm_meta(const swpm_file *f, uint64_t *length) {
    *length = f->meta_length;
    return f->meta;
}
const uint8_t *swpm_points(const swpm_file *f, uint32_t *stride) {
    *stride = f->stride;
    return f->vert + f->data_offset;
}
void swpm_point(const swpm_file *f, uint32_t vertex, float xyz[3]) {
    const uint8_t *p = f->vert + f->data_offset + (uint64_t)vertex * f->stride;
    int c;
    for (c = 0; c < 3; c++) { /* f32 LE assembled as a u32, then its bits: right on a big-endian host too */
        uint32_t u = swpm__u32(p + 4 * c);
        memcpy(&xyz[c], &u, 4);
    }
}
uint32_t swpm_attribute_count(const swpm_file *f) { return f->attribute_count; }
int swpm_attribute_at(const swpm_file *f, uint32_t i, swpm_attribute *out) {
    const uint8_t *d;
    if (i >= f->attribute_count) return 0;
    d = f->vert + 16 + 16 * (uint64_t)i;
    out->name = f->vert + swpm__u32(d);
    out->name_length = swpm__u16(d + 4);
    out->elem_type = d[6];
    out->elem_size = swpm__elem_sizes[d[6]];
    out->components = d[7];
    out->offset = swpm__u32(d + 8);
    out->data = f->vert + f->data_offset + out->offset;
    return 1;
}
uint32_t swpm_lod_vertex_count(const swpm_file *f, uint64_t k) { return swpm__u32(f->lods + 12 * (uint64_t)k); }
uint32_t swpm_lod_triangle_count(const swpm_file *f, uint64_t k) { return swpm__u32(f->lods + 12 * (uint64_t)k + 4); }
float swpm_lod_error(const swpm_file *f, uint64_t k) {
    float e;
    uint32_t u = swpm__u32(f->lods + 12 * (uint64_t)k + 8);
    memcpy(&e, &u, 4);
    return e;
}
const uint8_t *swpm_index_pool(const swpm_file *f, uint64_t *count, uint32_t *width) {
    *count = f->index_count;
    *width = f->index_width;
    return f->indx;
}
uint32_t swpm_index(const swpm_file *f, uint64_t i) { return swpm__uw(f->indx + i * f->index_width, f->index_width); }
const uint8_t *swpm_window_records(const swpm_file *f, uint32_t *row_bytes) {
    *row_bytes = (f->strips ? 4u : 3u) * f->offset_width;
    return f->wrec;
}
void swpm_window_record(const swpm_file *f, uint64_t k, uint32_t *first_index, uint32_t *triangle_count,
                        uint32_t *vertex_count, uint64_t *index_count) {
    uint32_t O = f->offset_width;
    const uint8_t *r = f->wrec + (uint64_t)k * (f->strips ? 4u : 3u) * O;
    *first_index = swpm__uw(r, O);
    *triangle_count = swpm__uw(r + O, O);
    *vertex_count = swpm__uw(r + 2 * O, O);
    *index_count = f->strips ? (uint64_t)swpm__uw(r + 3 * O, O) : 3 * (uint64_t)*triangle_count;
}
int swpm_window(const swpm_file *f, uint64_t lod, uint64_t *first_index, uint64_t *index_count,
                uint32_t *vertex_count) {
    uint32_t fi, tc;
    if (f->encoding != 2 || lod >= f->lod_count) return 0;
    swpm_window_record(f, lod, &fi, &tc, vertex_count, index_count);
    *first_index = fi;
    return 1;
}
uint64_t swpm_lod_for_triangles(const swpm_file *f, uint64_t target) {
    uint64_t lo = 0, hi = f->lod_count; /* first k with triangle_count(k) <= target (counts non-increasing) */
    while (lo < hi) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (swpm_lod_triangle_count(f, mid) <= target) hi = mid;
        else lo = mid + 1;
    }
    return lo < f->lod_count ? lo : f->lod_count - 1;
}
uint64_t swpm_lod_for_error(const swpm_file *f, double max_error) {
    uint64_t lo = 0, hi = f->lod_count; /* first k with error(k) > max_error: an f32 widened to double, exact */
    if (!(max_error >= 0.0)) return 0;  /* (NaN, negative: no LOD is that good) */
    while (lo < hi) {
        uint64_t mid = lo + (hi - lo) / 2;
        if ((double)swpm_lod_error(f, mid) > max_error) hi = mid;
        else lo = mid + 1;
    }
    return lo ? lo - 1 : 0;
}
int swpm_restart_index(const swpm_file *f, uint64_t *restart) {
    if (!f->strips && !f->has_restart) return 0;
    *restart = f->restart_index;
    return 1;
}

/* ---- streaming (format.md 4, 4.1) ---- */
static const uint8_t *swpm__rebase(const uint8_t *p, const uint8_t *old, const uint8_t *now) {
    return p ? now + (p - old) : p;
}
swpm_result swpm_prefix_finish(swpm_file *f, const uint8_t *bytes, size_t length) {
    swpm_result ok = {NULL, 0, 0, 0, 0};
    uint64_t len = (uint64_t)length, vo, vl, g;
    uint32_t crc;
    const uint8_t *old = f->bytes;
    int i;
    if (f->ranges) return swpm_ranges_finish(f, bytes, length, NULL, 0); /* (ranges: it checks them all) */
    /* in the order of format.md 5: step 1's length, then step 2's VERT CRC (the last entry) and padding */
    if (f->prefix && len < f->file_size) return swpm__err("SWPM_FILE_SIZE_MISMATCH", 40);
    if (f->prefix) { /* (a whole file was checked all through: only its views move to `bytes`) */
        vo = f->vert_offset;
        vl = swpm__u64(bytes + f->vert_entry + 16);
        crc = swpm__crc_update(swpm__crc_update(0xFFFFFFFFu, bytes + f->vert_entry, 4), bytes + vo, vl) ^ 0xFFFFFFFFu;
        if (crc != swpm__u32(bytes + f->vert_entry + 24))
            return swpm__err("SWPM_CHUNK_CRC_MISMATCH", f->vert_entry + 24);
        for (g = vo + vl; g < f->file_size; g++)
            if (bytes[g]) return swpm__err("SWPM_PADDING_NONZERO", vo + vl);
    }
    f->meta = swpm__rebase(f->meta, old, bytes);
    f->lods = swpm__rebase(f->lods, old, bytes);
    f->vert = swpm__rebase(f->vert, old, bytes);
    f->wrec = swpm__rebase(f->wrec, old, bytes);
    f->indx = swpm__rebase(f->indx, old, bytes);
    f->vrec = swpm__rebase(f->vrec, old, bytes);
    f->change_offsets = swpm__rebase(f->change_offsets, old, bytes);
    f->rcnt = swpm__rebase(f->rcnt, old, bytes);
    f->smap = swpm__rebase(f->smap, old, bytes);
    for (i = 0; i < 4; i++) f->level_arrays[i] = swpm__rebase(f->level_arrays[i], old, bytes);
    for (i = 0; i < 2; i++) f->level_lists[i] = swpm__rebase(f->level_lists[i], old, bytes);
    f->bytes = bytes;
    f->held = f->prefix ? len : f->held;
    f->prefix = 0;
    return ok;
}
int swpm_is_prefix(const swpm_file *f) { return f->prefix; }
int swpm_is_ranges(const swpm_file *f) { return f->ranges != NULL; }
/* 4.2: each LOD's held INDX elements below the vertices it draws (a level's list: its first LOD's; a strips'
 * restart index exempt), else SWPM_PREFIX_VIOLATION at the first element that is not, LODs in order */
static swpm_result swpm__check_drawn(const swpm_file *f) {
    swpm_result ok = {NULL, 0, 0, 0, 0};
    uint64_t k, first, count, io, lim, pos;
    int exempt = f->encoding == 2 ? f->strips : f->encoding == 3 ? f->has_restart : 0;
    if (!f->ranges || !f->indx_partial) return ok;
    io = (uint64_t)(f->indx - f->bytes);
    for (k = 0; k < f->lod_count; k++) {
        if (!swpm_lod_index_range(f, k, &first, &count) || count == 0) continue;
        if (swpm__held_to(f->ranges, f->range_count, f->held, io + first * f->index_width,
                          io + (first + count) * f->index_width) < io + (first + count) * f->index_width)
            continue;
        lim = swpm_lod_vertex_count(f, f->encoding == 3 || f->encoding == 4
                                           ? swpm__la(f, 0, swpm_level_of_lod(f, k)) : k);
        pos = swpm__first_at_least(f->indx, f->index_width, first, first + count, lim, exempt, f->restart_index);
        if (pos < first + count) return swpm__err("SWPM_PREFIX_VIOLATION", io + pos * f->index_width);
    }
    return ok;
}
swpm_result swpm_ranges_finish(swpm_file *f, const uint8_t *bytes, size_t length, void *scratch,
                               size_t scratch_bytes) {
    swpm_file g;
    swpm_result r;
    uint64_t q;
    if (f->ranges) /* the held ranges' bytes must be these (the old buffer is read: keep it until here) */
        for (q = 0; q < f->range_count; q++) {
            const swpm_range *h = &f->ranges[q];
            if (h->length && (h->offset + h->length > (uint64_t)length ||
                              memcmp(bytes + h->offset, f->bytes + h->offset, (size_t)h->length) != 0)) {
                swpm_result bad = {SWPM_READER_BAD_RANGES, 0, 0, 0, 0};
                return bad;
            }
        }
    /* the deferred checks need most of the file (CRCs, INDX's content and replays): checked all through */
    r = swpm__open(bytes, length, &g, scratch, scratch_bytes, 0, NULL, 0);
    if (!r.code) *f = g;
    return r;
}
uint64_t swpm_file_size(const swpm_file *f) { return f->file_size; }
uint64_t swpm_bytes_held(const swpm_file *f) { return f->held; }
uint64_t swpm_lod_needed_bytes(const swpm_file *f, uint64_t k) {
    return f->vert_offset + f->data_offset + (uint64_t)swpm_lod_vertex_count(f, k) * f->stride;
}
int swpm_lod_index_range(const swpm_file *f, uint64_t k, uint64_t *first, uint64_t *count) {
    uint64_t l;
    if (k >= f->lod_count) return 0;
    if (f->encoding == 2) {
        uint32_t vc;
        return swpm_window(f, k, first, count, &vc);
    }
    if (f->encoding == 3 || f->encoding == 4) { /* level_index_start, mixed level_static_start */
        l = swpm_level_of_lod(f, k);
        *first = swpm__la(f, 1, l);
        *count = swpm__la(f, 1, l + 1) - *first;
        return 1;
    }
    *first = 0;
    *count = f->index_count;
    return 1;
}
uint32_t swpm_lod_needed_ranges(const swpm_file *f, uint64_t k, swpm_range out[3]) {
    uint64_t io = (uint64_t)(f->indx - f->bytes), first, count;
    uint32_t n = 0;
    if (!swpm_lod_index_range(f, k, &first, &count)) return 0;
    out[n].offset = 0;
    out[n++].length = io;
    if (count) {
        out[n].offset = io + first * f->index_width;
        out[n++].length = count * f->index_width;
    }
    out[n].offset = f->vert_offset;
    out[n++].length = f->data_offset + (uint64_t)swpm_lod_vertex_count(f, k) * f->stride;
    return n;
}
int swpm_lod_drawable(const swpm_file *f, uint64_t k) {
    if (f->ranges) { /* 4.2: (a), (b) and (c) held; no byte of them is read */
        swpm_range r[3];
        uint32_t n = swpm_lod_needed_ranges(f, k, r), i;
        if (n == 0) return 0;
        for (i = 0; i < n; i++)
            if (swpm__held_to(f->ranges, f->range_count, f->held, r[i].offset, r[i].offset + r[i].length) <
                r[i].offset + r[i].length)
                return 0;
        return 1;
    }
    return k < f->lod_count && swpm_lod_needed_bytes(f, k) <= f->held;
}
uint64_t swpm_finest_drawable_lod(const swpm_file *f) {
    uint64_t lo = 0, hi = f->lod_count; /* needed bytes do not increase with k: the first drawable one */
    if (f->ranges) { /* (ranges: the drawable LODs need not be consecutive) */
        while (lo < hi && !swpm_lod_drawable(f, lo)) lo++;
        return lo;
    }
    while (lo < hi) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (swpm_lod_needed_bytes(f, mid) <= f->held) hi = mid;
        else lo = mid + 1;
    }
    return lo;
}
uint64_t swpm_smap_band_count(const swpm_file *f) { return f->smap ? f->smap_bands : 0; }
int swpm_smap_band(const swpm_file *f, uint64_t b, uint32_t *first_lod, uint32_t *lod_count, uint32_t *range_count,
                   uint64_t *prefix_length) {
    const uint8_t *p;
    if (!f->smap || b >= f->smap_bands) return 0;
    p = f->smap + 8 + 24 * b;
    *first_lod = swpm__u32(p);
    *lod_count = swpm__u32(p + 4);
    *range_count = swpm__u32(p + 12);
    *prefix_length = swpm__u64(p + 16);
    return 1;
}
int swpm_smap_range(const swpm_file *f, uint64_t b, uint32_t r, uint64_t *offset, uint64_t *length) {
    const uint8_t *p;
    uint64_t at;
    if (!f->smap || b >= f->smap_bands) return 0;
    p = f->smap + 8 + 24 * b;
    if (r >= swpm__u32(p + 12)) return 0;
    at = (uint64_t)swpm__u32(p + 8) + r;
    if (at >= f->smap_ranges) return 0;
    p = f->smap + 8 + 24 * f->smap_bands + 16 * at;
    *offset = swpm__u64(p);
    *length = swpm__u64(p + 8);
    return 1;
}

#endif /* SWPM_READER_IMPLEMENTED */
#endif /* SWPM_READER_IMPLEMENTATION */
