/*
 * swpm_reader.h -- a single-header C99 reader for SWPM v1 files of the sliding-window encoding
 * (list pools and SW_STRIPS strip pools, u16/u32 idx, OFFSET32), written from spec/format.md and
 * spec/errors.md (Forsyth's sliding-window VIPM, "Comparison of VIPM Methods", Game Programming Gems 2).
 *
 * Use: in exactly one .c file
 *     #define SWPM_READER_IMPLEMENTATION
 *     #include "swpm_reader.h"
 *
 * What it does: swpm_open() validates a file held in the caller's memory as format.md section 5 asks of a
 * reader (header, chunk table, CRC-32s, required chunks, META, LODS, VERT, WREC, INDX, the windows, the
 * vertex prefix property, strip windows' starts and decoded triangle counts) and returns the FIRST error
 * in the order of section 5 "Reporting" as its stable code (errors.md) and byte offset. The accessors then
 * give zero-copy views of the caller's bytes: nothing is allocated, nothing is copied, and no byte outside
 * [bytes, bytes + length) is read. Every sum is computed without wrapping (format.md section 1).
 *
 * What it does not do:
 *  - files of the other three encodings (vanilla, skip-strip, mixed) are refused after the header and
 *    chunk-table checks with the reader's own code SWPM_READER_UNSUPPORTED_ENCODING (offset 20, the
 *    features field); a header or table error found first is reported instead;
 *  - warnings and infos (SWPM_STREAM_ORDER, SWPM_FILE_TRAILING_BYTES, SWPM_VERT_NONFINITE, ...) are not
 *    reported: a file is accepted iff it has no error;
 *  - SMAP (ancillary, format.md section 4) and unknown ancillary chunks are skipped, not validated;
 *  - META is validated (strict RFC 8259 with the limits of section 3.1) and its params read, but not
 *    exposed as a tree: swpm_meta() gives its bytes.
 *  - Checking a META object for duplicate keys walks the object once per key (O(keys^2) per object):
 *    no allocation, fine for the kilobyte META writers emit.
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

/* The reader's own code for a valid-so-far file of another encoding (not an errors.md code). */
#define SWPM_READER_UNSUPPORTED_ENCODING "SWPM_READER_UNSUPPORTED_ENCODING"

/* Result of swpm_open: code is NULL on success, else the first error's code string (errors.md); offset is
 * the absolute byte offset it concerns, valid when has_offset is 1 (SWPM_CHUNK_MISSING has none). */
typedef struct swpm_result {
    const char *code;
    uint64_t offset;
    int has_offset;
} swpm_result;

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
} swpm_file;

/* Open and validate a file (format.md 5). file is filled only on success. */
swpm_result swpm_open(const uint8_t *bytes, size_t length, swpm_file *file);

/* Header (2.1): features word, W, O, V, L. */
uint32_t swpm_features(const swpm_file *f);
uint32_t swpm_index_width(const swpm_file *f);
uint32_t swpm_offset_width(const swpm_file *f);
uint32_t swpm_vertex_count(const swpm_file *f);
uint64_t swpm_lod_count(const swpm_file *f);
/* META payload (3.1): UTF-8 JSON, validated; not NUL-terminated. */
const uint8_t *swpm_meta(const swpm_file *f, uint64_t *length);

/* VERT (3.3): points are f32[3] at byte 0 of each record, stride bytes apart, maybe unaligned. */
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
 * vertices [0, vertex_count). Returns 0 if lod >= L. */
int swpm_window(const swpm_file *f, uint64_t lod, uint64_t *first_index, uint64_t *index_count,
                uint32_t *vertex_count);

/* The finest LOD that draws at most target triangles; the coarsest LOD if none does (README, Python's
 * ProgressiveMesh.lod_for_triangles; LODS triangle counts are non-increasing). */
uint64_t swpm_lod_for_triangles(const swpm_file *f, uint64_t target);

/* SW_STRIPS: 1 and *restart = params.restart_index (>= V; the largest idx value from current writers).
 * 0 for a list pool. */
int swpm_restart_index(const swpm_file *f, uint64_t *restart);

#ifdef __cplusplus
}
#endif
#endif /* SWPM_READER_H */

#ifdef SWPM_READER_IMPLEMENTATION
#ifndef SWPM_READER_IMPLEMENTED
#define SWPM_READER_IMPLEMENTED

#include <string.h>

/* ---- little-endian loads (no alignment assumed) ---- */
static uint32_t swpm__u16(const uint8_t *p) { return (uint32_t)p[0] | ((uint32_t)p[1] << 8); }
static uint32_t swpm__u32(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t swpm__u64(const uint8_t *p) { return (uint64_t)swpm__u32(p) | ((uint64_t)swpm__u32(p + 4) << 32); }
static uint32_t swpm__uw(const uint8_t *p, uint32_t w) { return w == 2 ? swpm__u16(p) : swpm__u32(p); }

/* ---- CRC-32 (ISO-HDLC / zlib: reflected 0x04C11DB7, init and final xor 0xFFFFFFFF; format.md 2.1) ---- */
static const uint32_t swpm__crc_table[256] = {
    0x00000000u, 0x77073096u, 0xee0e612cu, 0x990951bau, 0x076dc419u, 0x706af48fu,
    0xe963a535u, 0x9e6495a3u, 0x0edb8832u, 0x79dcb8a4u, 0xe0d5e91eu, 0x97d2d988u,
    0x09b64c2bu, 0x7eb17cbdu, 0xe7b82d07u, 0x90bf1d91u, 0x1db71064u, 0x6ab020f2u,
    0xf3b97148u, 0x84be41deu, 0x1adad47du, 0x6ddde4ebu, 0xf4d4b551u, 0x83d385c7u,
    0x136c9856u, 0x646ba8c0u, 0xfd62f97au, 0x8a65c9ecu, 0x14015c4fu, 0x63066cd9u,
    0xfa0f3d63u, 0x8d080df5u, 0x3b6e20c8u, 0x4c69105eu, 0xd56041e4u, 0xa2677172u,
    0x3c03e4d1u, 0x4b04d447u, 0xd20d85fdu, 0xa50ab56bu, 0x35b5a8fau, 0x42b2986cu,
    0xdbbbc9d6u, 0xacbcf940u, 0x32d86ce3u, 0x45df5c75u, 0xdcd60dcfu, 0xabd13d59u,
    0x26d930acu, 0x51de003au, 0xc8d75180u, 0xbfd06116u, 0x21b4f4b5u, 0x56b3c423u,
    0xcfba9599u, 0xb8bda50fu, 0x2802b89eu, 0x5f058808u, 0xc60cd9b2u, 0xb10be924u,
    0x2f6f7c87u, 0x58684c11u, 0xc1611dabu, 0xb6662d3du, 0x76dc4190u, 0x01db7106u,
    0x98d220bcu, 0xefd5102au, 0x71b18589u, 0x06b6b51fu, 0x9fbfe4a5u, 0xe8b8d433u,
    0x7807c9a2u, 0x0f00f934u, 0x9609a88eu, 0xe10e9818u, 0x7f6a0dbbu, 0x086d3d2du,
    0x91646c97u, 0xe6635c01u, 0x6b6b51f4u, 0x1c6c6162u, 0x856530d8u, 0xf262004eu,
    0x6c0695edu, 0x1b01a57bu, 0x8208f4c1u, 0xf50fc457u, 0x65b0d9c6u, 0x12b7e950u,
    0x8bbeb8eau, 0xfcb9887cu, 0x62dd1ddfu, 0x15da2d49u, 0x8cd37cf3u, 0xfbd44c65u,
    0x4db26158u, 0x3ab551ceu, 0xa3bc0074u, 0xd4bb30e2u, 0x4adfa541u, 0x3dd895d7u,
    0xa4d1c46du, 0xd3d6f4fbu, 0x4369e96au, 0x346ed9fcu, 0xad678846u, 0xda60b8d0u,
    0x44042d73u, 0x33031de5u, 0xaa0a4c5fu, 0xdd0d7cc9u, 0x5005713cu, 0x270241aau,
    0xbe0b1010u, 0xc90c2086u, 0x5768b525u, 0x206f85b3u, 0xb966d409u, 0xce61e49fu,
    0x5edef90eu, 0x29d9c998u, 0xb0d09822u, 0xc7d7a8b4u, 0x59b33d17u, 0x2eb40d81u,
    0xb7bd5c3bu, 0xc0ba6cadu, 0xedb88320u, 0x9abfb3b6u, 0x03b6e20cu, 0x74b1d29au,
    0xead54739u, 0x9dd277afu, 0x04db2615u, 0x73dc1683u, 0xe3630b12u, 0x94643b84u,
    0x0d6d6a3eu, 0x7a6a5aa8u, 0xe40ecf0bu, 0x9309ff9du, 0x0a00ae27u, 0x7d079eb1u,
    0xf00f9344u, 0x8708a3d2u, 0x1e01f268u, 0x6906c2feu, 0xf762575du, 0x806567cbu,
    0x196c3671u, 0x6e6b06e7u, 0xfed41b76u, 0x89d32be0u, 0x10da7a5au, 0x67dd4accu,
    0xf9b9df6fu, 0x8ebeeff9u, 0x17b7be43u, 0x60b08ed5u, 0xd6d6a3e8u, 0xa1d1937eu,
    0x38d8c2c4u, 0x4fdff252u, 0xd1bb67f1u, 0xa6bc5767u, 0x3fb506ddu, 0x48b2364bu,
    0xd80d2bdau, 0xaf0a1b4cu, 0x36034af6u, 0x41047a60u, 0xdf60efc3u, 0xa867df55u,
    0x316e8eefu, 0x4669be79u, 0xcb61b38cu, 0xbc66831au, 0x256fd2a0u, 0x5268e236u,
    0xcc0c7795u, 0xbb0b4703u, 0x220216b9u, 0x5505262fu, 0xc5ba3bbeu, 0xb2bd0b28u,
    0x2bb45a92u, 0x5cb36a04u, 0xc2d7ffa7u, 0xb5d0cf31u, 0x2cd99e8bu, 0x5bdeae1du,
    0x9b64c2b0u, 0xec63f226u, 0x756aa39cu, 0x026d930au, 0x9c0906a9u, 0xeb0e363fu,
    0x72076785u, 0x05005713u, 0x95bf4a82u, 0xe2b87a14u, 0x7bb12baeu, 0x0cb61b38u,
    0x92d28e9bu, 0xe5d5be0du, 0x7cdcefb7u, 0x0bdbdf21u, 0x86d3d2d4u, 0xf1d4e242u,
    0x68ddb3f8u, 0x1fda836eu, 0x81be16cdu, 0xf6b9265bu, 0x6fb077e1u, 0x18b74777u,
    0x88085ae6u, 0xff0f6a70u, 0x66063bcau, 0x11010b5cu, 0x8f659effu, 0xf862ae69u,
    0x616bffd3u, 0x166ccf45u, 0xa00ae278u, 0xd70dd2eeu, 0x4e048354u, 0x3903b3c2u,
    0xa7672661u, 0xd06016f7u, 0x4969474du, 0x3e6e77dbu, 0xaed16a4au, 0xd9d65adcu,
    0x40df0b66u, 0x37d83bf0u, 0xa9bcae53u, 0xdebb9ec5u, 0x47b2cf7fu, 0x30b5ffe9u,
    0xbdbdf21cu, 0xcabac28au, 0x53b39330u, 0x24b4a3a6u, 0xbad03605u, 0xcdd70693u,
    0x54de5729u, 0x23d967bfu, 0xb3667a2eu, 0xc4614ab8u, 0x5d681b02u, 0x2a6f2b94u,
    0xb40bbe37u, 0xc30c8ea1u, 0x5a05df1bu, 0x2d02ef8du
};
static uint32_t swpm__crc_update(uint32_t c, const uint8_t *p, uint64_t n) {
    uint64_t i;
    for (i = 0; i < n; i++) c = swpm__crc_table[(c ^ p[i]) & 0xFFu] ^ (c >> 8);
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
    uint32_t v, w;
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
    return r;
}

static const uint32_t swpm__elem_sizes[10] = {0, 1, 1, 2, 2, 4, 4, 2, 4, 8};

/* VERT layout (format.md 3.3), in the order the spec gives; fills V, A, stride, data_offset. */
static swpm_result swpm__vert(const uint8_t *p, uint64_t len, uint64_t entry, uint64_t off, swpm_file *f) {
    uint32_t V, A, stride, data_offset, i, k;
    uint64_t names_start;
    swpm_result ok = {0, 0, 0};
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

swpm_result swpm_open(const uint8_t *bytes, size_t length, swpm_file *file) {
    swpm_file f;
    swpm_result ok = {0, 0, 0};
    uint64_t len = (uint64_t)length, eof, table_offset, file_size, table_end, end, last = 0;
    uint32_t header_size, features, count, enc_bits, i, W, O;
    int enc = 0, one_encoding, have_last = 0;
    int64_t first[SWPM__KINDS];
    uint32_t crc;
    uint8_t zero4[4] = {0, 0, 0, 0};
    static const uint8_t magic[8] = {0x53, 0x57, 0x50, 0x4D, 0x0D, 0x0A, 0x1A, 0x0A};

    memset(&f, 0, sizeof f);
    /* ---- step 1: header (format.md 2.1, 5) ---- */
    if (len < 64) {
        if (len >= 8 && memcmp(bytes, magic, 8) != 0) return swpm__err("SWPM_HEADER_BAD_MAGIC", 0);
        return swpm__err("SWPM_HEADER_TRUNCATED", 0);
    }
    if (memcmp(bytes, magic, 8) != 0) return swpm__err("SWPM_HEADER_BAD_MAGIC", 0);
    f.major = swpm__u16(bytes + 8);
    f.minor = swpm__u16(bytes + 10);
    if (f.major != 1) return swpm__err("SWPM_HEADER_UNSUPPORTED_MAJOR", 8);
    header_size = swpm__u32(bytes + 12);
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
    file_size = swpm__u64(bytes + 40);
    if (file_size > len) return swpm__err("SWPM_FILE_SIZE_MISMATCH", 40);
    eof = file_size < len ? file_size : len; /* bytes after file_size are ignored (a warning) */
    table_offset = swpm__u64(bytes + 32);
    if (table_offset < header_size || table_offset % 8) return swpm__err("SWPM_TABLE_BAD_OFFSET", 32);
    count = swpm__u32(bytes + 24);
    if (count > 1024) return swpm__err("SWPM_TABLE_TOO_LARGE", 24);
    if (table_offset > eof || 32 * (uint64_t)count > eof - table_offset) return swpm__err("SWPM_TABLE_TRUNCATED", 24);
    table_end = table_offset + 32 * (uint64_t)count;
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
        {
            uint64_t g;
            for (g = end; g < off && g < eof; g++)
                if (bytes[g]) return swpm__err("SWPM_PADDING_NONZERO", end);
        }
        have_last = 1;
        last = off;
        end = off + clen; /* in bounds: no wrap */
        crc = swpm__crc_update(swpm__crc_update(0xFFFFFFFFu, bytes + eo, 4), bytes + off, clen) ^ 0xFFFFFFFFu;
        if (crc != swpm__u32(bytes + eo + 24)) return swpm__err("SWPM_CHUNK_CRC_MISMATCH", eo + 24);
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
    {
        uint64_t g; /* padding after the last payload: reported at the gap's start */
        for (g = end; g < eof; g++)
            if (bytes[g]) return swpm__err("SWPM_PADDING_NONZERO", end);
    }
    for (i = 0; swpm__critical_order[enc][i] >= 0; i++)
        if (first[swpm__critical_order[enc][i]] < 0) {
            swpm_result r = {"SWPM_CHUNK_MISSING", 0, 0};
            return r;
        }
    if (enc != 2) return swpm__err(SWPM_READER_UNSUPPORTED_ENCODING, 20);

    W = (features & SWPM_FEATURE_INDEX32) ? 4u : 2u;
    O = (features & (SWPM_FEATURE_INDEX32 | SWPM_FEATURE_OFFSET32)) ? 4u : 2u;
    f.bytes = bytes;
    f.length = eof;
    f.features = features;
    f.index_width = W;
    f.offset_width = O;
    f.strips = (features & SWPM_FEATURE_SW_STRIPS) != 0;
    {
        uint64_t pe[SWPM__KINDS], pl[SWPM__KINDS];
        for (i = 0; i < SWPM__KINDS; i++) {
            uint64_t eo = table_offset + 32 * (uint64_t)(first[i] < 0 ? 0 : first[i]);
            pe[i] = eo;
            pl[i] = first[i] < 0 ? 0 : swpm__u64(bytes + eo + 16);
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
                !(j.s[v] == '"' && swpm__jstreq_lit(&j, v, "sliding-window")))
                return swpm__err("SWPM_META_BAD_FIELD", SWPM__OFF(SWPM__META));
            /* 3.5: primitive "strip" exactly with SW_STRIPS (missing reads "list"); restart_index null or an
             * integer in [0, 2^32), required with SW_STRIPS */
            {
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
            for (k = 0; k < nidx; k++) {
                uint64_t v = SWPM__X(k);
                if (v >= V && !(f.strips && v == f.restart_index))
                    return swpm__err("SWPM_INDEX_OUT_OF_RANGE", ibase + W * k);
            }
            if (f.strips)
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
            {
                uint64_t seen0 = 0, seen1 = 0;
                for (k = L; k-- > 0;) {
                    uint64_t s = SWPM__W(k, 0), e = s + SWPM__ICOUNT(k), lim = SWPM__W(k, 2), i2;
                    uint64_t e1 = e < best ? e : best;
                    for (i2 = s; i2 < e1; i2++) {
                        uint64_t v;
                        if (i2 >= seen0 && i2 < seen1) {
                            i2 = seen1 - 1;
                            continue;
                        }
                        v = SWPM__X(i2);
                        if (v >= lim && !(f.strips && v == f.restart_index)) {
                            best = i2;
                            break;
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
            if (f.strips) {
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
    }
    *file = f;
    return ok;
}

/* ---- accessors ---- */
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
    memcpy(xyz, f->vert + f->data_offset + (uint64_t)vertex * f->stride, 12); /* f32 LE: a LE host */
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
    if (lod >= f->lod_count) return 0;
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
int swpm_restart_index(const swpm_file *f, uint64_t *restart) {
    if (!f->strips) return 0;
    *restart = f->restart_index;
    return 1;
}

#endif /* SWPM_READER_IMPLEMENTED */
#endif /* SWPM_READER_IMPLEMENTATION */
