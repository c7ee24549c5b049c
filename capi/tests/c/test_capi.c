/*
 * The C API from C (scripts/test-capi builds this under AddressSanitizer and
 * UndefinedBehaviorSanitizer):
 *   test_capi VECTORS_DIR GOLDEN_SUMMARY
 * 1. Golden bytes: every case of the golden summary (tests/golden/SUMMARY.txt:
 *    "case output bytes fnv1a64") from its vector's f0.pgm, f1.pgm: both
 *    scalings' RGB and the six f32 planes of fields.bin.
 * 2. Row callbacks (narrow tiles) and row streaming equal whole frames, in
 *    every scaling and variant, with fields.
 * 3. Every rf_status for the bad input that should produce it.
 * Prints one line per check and closes with "N passed, N failed".
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "reynoldsflow.h"

static int passed, failed;

static void check(int ok, const char *what, const char *detail) {
  if (ok) {
    passed++;
  } else {
    failed++;
    printf("FAIL %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
  }
}

static void check_status(rf_status got, rf_status want, const char *what) {
  char detail[256];
  snprintf(detail, sizeof detail, "got %d (%s), want %d (%s)", (int)got, rf_strerror((int)got),
           (int)want, rf_strerror((int)want));
  check(got == want, what, detail);
}

static uint64_t fnv1a(const void *bytes, size_t n) {
  const uint8_t *b = bytes;
  uint64_t h = 0xcbf29ce484222325ull;
  for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001b3ull;
  return h;
}

/* A binary PGM (P5, maxval 255), header comments allowed. */
static uint8_t *read_pgm(const char *path, uint32_t *w, uint32_t *h) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  char magic[3] = {0};
  unsigned vals[3];
  int got = fscanf(f, "%2s", magic);
  for (int i = 0; got == 1 && i < 3; i++) {
    int c;
    while ((c = fgetc(f)) == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '#')
      if (c == '#')
        while ((c = fgetc(f)) != '\n' && c != EOF) {
        }
    ungetc(c, f);
    if (fscanf(f, "%u", &vals[i]) != 1) got = 0;
  }
  uint8_t *pixels = NULL;
  if (got == 1 && strcmp(magic, "P5") == 0 && vals[2] == 255 && fgetc(f) != EOF) {
    *w = vals[0];
    *h = vals[1];
    pixels = malloc((size_t)*w * *h);
    if (pixels && fread(pixels, 1, (size_t)*w * *h, f) != (size_t)*w * *h) {
      free(pixels);
      pixels = NULL;
    }
  }
  fclose(f);
  return pixels;
}

typedef struct {
  uint32_t w, h;
  uint8_t *prev, *next;
} pair;

/* An engine for cfg in a fresh heap block (the test's memory, not the library's). */
static rf_engine *engine_for(const rf_config *cfg, void **block) {
  size_t bytes = 0;
  rf_engine *e = NULL;
  if (rf_workspace_size(cfg, &bytes) != RF_OK) return NULL;
  /* One byte off an aligned address: the library aligns for itself. */
  uint8_t *mem = malloc(bytes + 1);
  *block = mem;
  if (!mem || rf_init(mem + 1, bytes, cfg, &e) != RF_OK) return NULL;
  return e;
}

typedef struct {
  uint32_t w;
  uint8_t *rgb;
  float *m_c, *m_d, *v_c, *v_d;
  size_t segments;
  uint32_t last_y;
  int out_of_order;
} row_collector;

static void collect(void *user, const rf_row *row) {
  row_collector *c = user;
  size_t at = (size_t)row->y * c->w + row->x;
  memcpy(c->rgb + 3 * at, row->rgb, 3 * (size_t)row->width);
  memcpy(c->m_c + at, row->m_c, sizeof(float) * row->width);
  memcpy(c->m_d + at, row->m_d, sizeof(float) * row->width);
  if (row->v_c) memcpy(c->v_c + 2 * at, row->v_c, 2 * sizeof(float) * row->width);
  if (row->v_d) memcpy(c->v_d + 2 * at, row->v_d, 2 * sizeof(float) * row->width);
  if (c->segments > 0 && row->x == 0 && row->y != c->last_y + 1) c->out_of_order = 1;
  c->last_y = row->y;
  c->segments++;
}

typedef struct {
  size_t n;
  uint8_t *rgb;
  float *m_c, *m_d, *v_c, *v_d;
} frame_out;

static frame_out frame_alloc(size_t n) {
  frame_out f = {n, calloc(3 * n, 1), calloc(n, 4), calloc(n, 4), calloc(2 * n, 4), calloc(2 * n, 4)};
  return f;
}

static void frame_free(frame_out *f) {
  free(f->rgb);
  free(f->m_c);
  free(f->m_d);
  free(f->v_c);
  free(f->v_d);
}

static rf_outputs outputs_of(frame_out *f) {
  rf_outputs o = {f->rgb, 3 * f->n, f->v_c, 2 * f->n, f->v_d, 2 * f->n, f->m_c, f->n, f->m_d, f->n};
  return o;
}

static int frames_equal(const frame_out *a, const frame_out *b, int fields) {
  size_t n = a->n;
  return memcmp(a->rgb, b->rgb, 3 * n) == 0 && memcmp(a->m_c, b->m_c, 4 * n) == 0 &&
         memcmp(a->m_d, b->m_d, 4 * n) == 0 &&
         (!fields || (memcmp(a->v_c, b->v_c, 8 * n) == 0 && memcmp(a->v_d, b->v_d, 8 * n) == 0));
}

/* 1. The golden summary's cases. */
static void golden(const char *vectors, const char *summary_path) {
  FILE *summary = fopen(summary_path, "r");
  check(summary != NULL, "open the golden summary", summary_path);
  if (!summary) return;
  char line[512], name[128], output[64];
  unsigned long long bytes, want;
  int cases = 0;
  while (fgets(line, sizeof line, summary)) {
    if (strncmp(line, "# changes", 9) == 0) break;
    if (sscanf(line, "%127s %63s %llu %llx", name, output, &bytes, &want) != 4) continue;
    char path[1024];
    pair p;
    snprintf(path, sizeof path, "%s/%s/f0.pgm", vectors, name);
    p.prev = read_pgm(path, &p.w, &p.h);
    snprintf(path, sizeof path, "%s/%s/f1.pgm", vectors, name);
    uint32_t w2 = 0, h2 = 0;
    p.next = read_pgm(path, &w2, &h2);
    check(p.prev && p.next && w2 == p.w && h2 == p.h, "read the case's frames", path);
    if (!p.prev || !p.next) continue;
    rf_config cfg;
    rf_config_init(&cfg, p.w, p.h);
    if (strcmp(output, "rep_fixed.png") == 0) cfg.scaling = RF_SCALING_FIXED; /* gains 8, 32 */
    void *block = NULL;
    rf_engine *e = engine_for(&cfg, &block);
    check(e != NULL, "engine for a golden case", name);
    size_t n = (size_t)p.w * p.h;
    frame_out f = frame_alloc(n);
    rf_outputs out = outputs_of(&f);
    if (e) check_status(rf_represent(e, p.prev, p.next, n, 0, &out), RF_OK, name);
    uint64_t got;
    size_t got_bytes;
    if (strcmp(output, "fields.bin") == 0) {
      /* vcx, vcy, vdx, vdy, |v_c|, |v_d| planes, little-endian f32. */
      float *planes = malloc(24 * n);
      for (size_t i = 0; i < n; i++) {
        planes[i] = f.v_c[2 * i];
        planes[n + i] = f.v_c[2 * i + 1];
        planes[2 * n + i] = f.v_d[2 * i];
        planes[3 * n + i] = f.v_d[2 * i + 1];
        planes[4 * n + i] = f.m_c[i];
        planes[5 * n + i] = f.m_d[i];
      }
      got = fnv1a(planes, 24 * n);
      got_bytes = 24 * n;
      free(planes);
    } else {
      got = fnv1a(f.rgb, 3 * n);
      got_bytes = 3 * n;
    }
    char detail[256];
    snprintf(detail, sizeof detail, "%s %s: %zu bytes fnv %016llx, golden %llu bytes %016llx", name,
             output, got_bytes, (unsigned long long)got, bytes, want);
    check(got == want && got_bytes == bytes, "golden bytes", detail);
    cases++;
    frame_free(&f);
    free(block);
    free(p.prev);
    free(p.next);
  }
  fclose(summary);
  printf("golden: %d outputs compared\n", cases);
  check(cases >= 30, "the golden summary lists the cases", NULL);
}

/* A deterministic textured pair with motion (xorshift noise, shifted). */
static pair make_pair(uint32_t w, uint32_t h, uint32_t seed) {
  pair p = {w, h, malloc((size_t)w * h), malloc((size_t)w * h)};
  uint32_t s = seed * 2654435761u + 1;
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++) {
      s ^= s << 13;
      s ^= s >> 17;
      s ^= s << 5;
      uint8_t smooth = (uint8_t)(128 + 100 * sin(0.21 * (x + seed) + 0.13 * y));
      p.prev[y * w + x] = (uint8_t)(smooth / 2 + (s & 63));
    }
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++)
      p.next[y * w + x] = p.prev[y * w + (x >= 2 ? x - 2 : 0)];
  return p;
}

/* 2. Rows and streams against whole frames. */
static void rows_and_streams(void) {
  const uint32_t w = 53, h = 37;
  const size_t n = (size_t)w * h;
  const uint32_t scalings[] = {RF_SCALING_PER_FRAME_MINMAX, RF_SCALING_PREVIOUS_FRAME_MINMAX,
                               RF_SCALING_FIXED};
  const uint32_t variants[] = {RF_VARIANT_DC, RF_VARIANT_DC0, RF_VARIANT_CD};
  pair pairs[3] = {make_pair(w, h, 1), make_pair(w, h, 2), make_pair(w, h, 3)};
  for (int si = 0; si < 3; si++) {
    for (int vi = 0; vi < 3; vi++) {
      char what[128];
      snprintf(what, sizeof what, "scaling %u variant %u", scalings[si], variants[vi]);
      rf_config whole_cfg;
      rf_config_init(&whole_cfg, w, h);
      whole_cfg.scaling = scalings[si];
      whole_cfg.variant = variants[vi];
      whole_cfg.k_d = 20.5;
      whole_cfg.k_c = 40.25;
      rf_config narrow_cfg = whole_cfg, stream_cfg = whole_cfg;
      narrow_cfg.tile_width = 9; /* 6 tiles, the last 8 wide */
      narrow_cfg.flags = RF_FLAG_ROW_FIELDS;
      stream_cfg.flags = RF_FLAG_ROW_FIELDS;
      void *b1, *b2, *b3;
      rf_engine *whole = engine_for(&whole_cfg, &b1), *narrow = engine_for(&narrow_cfg, &b2),
                *streamer = engine_for(&stream_cfg, &b3);
      check(whole && narrow && streamer, "engines", what);
      if (!whole || !narrow || !streamer) return;
      for (int k = 0; k < 3; k++) { /* three pairs: previous-frame scales carry over */
        frame_out a = frame_alloc(n), b = frame_alloc(n), c = frame_alloc(n);
        rf_outputs out = outputs_of(&a);
        check_status(rf_represent(whole, pairs[k].prev, pairs[k].next, n, 0, &out), RF_OK, what);
        row_collector rows = {w, b.rgb, b.m_c, b.m_d, b.v_c, b.v_d, 0, 0, 0};
        check_status(rf_represent_rows(narrow, pairs[k].prev, pairs[k].next, n, w, collect, &rows),
                     RF_OK, what);
        check(rows.segments == 6u * h, "a segment per tile row", what);
        check(frames_equal(&a, &b, 1), "rows (9-px tiles) equal the whole frame", what);
        if (scalings[si] == RF_SCALING_PER_FRAME_MINMAX) {
          check_status(rf_stream_begin(streamer), RF_ERR_STREAM_NEEDS_KNOWN_SCALE, what);
        } else {
          row_collector streamed = {w, c.rgb, c.m_c, c.m_d, c.v_c, c.v_d, 0, 0, 0};
          check_status(rf_stream_begin(streamer), RF_OK, what);
          for (uint32_t y = 0; y < h; y++) {
            uint32_t in = 99;
            rf_stream_rows_in(streamer, &in);
            check(in == y, "rows in", what);
            check_status(rf_stream_push(streamer, pairs[k].prev + y * w, pairs[k].next + y * w, w,
                                        collect, &streamed),
                         RF_OK, what);
            /* Output row y - 7 has left once row y is in. */
            if (y >= 7 && y + 1 < h) check(streamed.segments == y - 6, "rows leave early", what);
          }
          check(streamed.segments == h && !streamed.out_of_order, "every row once, in order", what);
          check(frames_equal(&a, &c, 1), "stream equals the whole frame", what);
          check_status(rf_stream_push(streamer, pairs[k].prev, pairs[k].next, w, collect, &streamed),
                       RF_ERR_NO_STREAM, "the stream ended with its last row");
        }
        frame_free(&a);
        frame_free(&b);
        frame_free(&c);
      }
      free(b1);
      free(b2);
      free(b3);
    }
  }
  for (int k = 0; k < 3; k++) {
    free(pairs[k].prev);
    free(pairs[k].next);
  }
}

/* 3. Every status from the input that should produce it. */
static void calls_back_into_the_engine(void *user, const rf_row *row) {
  (void)row;
  rf_engine **e = user;
  static uint8_t frame[64 * 48];
  rf_outputs none = {0};
  rf_status s = rf_represent(*e, frame, frame, sizeof frame, 0, &none);
  if (s != RF_ERR_BUSY) e[1] = NULL; /* flags the failure to the caller */
}

static void statuses(void) {
  const uint32_t w = 64, h = 48;
  const size_t n = (size_t)w * h;
  pair p = make_pair(w, h, 7);
  rf_config cfg, bad;
  check_status(rf_config_init(NULL, w, h), RF_ERR_NULL_POINTER, "rf_config_init(NULL)");
  rf_config_init(&cfg, w, h);
  size_t bytes = 0;
  check_status(rf_workspace_size(&cfg, NULL), RF_ERR_NULL_POINTER, "rf_workspace_size(.., NULL)");
  check_status(rf_workspace_size(&cfg, &bytes), RF_OK, "rf_workspace_size");
  check(bytes >= 252 * (w + 14) && bytes < 252 * (w + 14) + 2048, "workspace about 252 B a column",
        NULL);
  for (uint32_t tw = 1; tw < 3000; tw += 37) {
    for (uint32_t flags = 0; flags <= RF_FLAG_ROW_FIELDS; flags++) {
      rf_config wide;
      size_t need = 0;
      rf_config_init(&wide, 3000, 2);
      wide.tile_width = tw;
      wide.flags = flags;
      rf_workspace_size(&wide, &need);
      check(need <= RF_WORKSPACE_BYTES(tw, flags) &&
                RF_WORKSPACE_BYTES(tw, flags) - need <= RF_WORKSPACE_OVERHEAD,
            "RF_WORKSPACE_BYTES bounds rf_workspace_size closely", NULL);
    }
  }
  static uint8_t static_memory[RF_WORKSPACE_BYTES(64, 0)];
  rf_engine *from_static = NULL;
  check_status(rf_init(static_memory, sizeof static_memory, &cfg, &from_static), RF_OK,
               "rf_init in a static array of RF_WORKSPACE_BYTES");

  struct {
    const char *what;
    rf_status want;
  } cases[] = {
      {"width 0", RF_ERR_EMPTY_FRAME},
      {"width 70000", RF_ERR_FRAME_TOO_LARGE},
      {"scale 2/1", RF_ERR_SCALE_OUT_OF_RANGE},
      {"scale 0/1", RF_ERR_SCALE_OUT_OF_RANGE},
      {"lambda NaN", RF_ERR_LAMBDA_OUT_OF_RANGE},
      {"lambda 1", RF_ERR_LAMBDA_OUT_OF_RANGE},
      {"lambda 0", RF_ERR_LAMBDA_OUT_OF_RANGE},
      {"gain -1", RF_ERR_GAIN_OUT_OF_RANGE},
      {"gain NaN", RF_ERR_GAIN_OUT_OF_RANGE},
      {"gain 65536", RF_ERR_GAIN_OUT_OF_RANGE},
      {"scaling 7", RF_ERR_BAD_SCALING},
      {"variant 9", RF_ERR_BAD_VARIANT},
      {"tile wider than the frame", RF_ERR_BAD_TILE_WIDTH},
      {"flags 0x80", RF_ERR_BAD_FLAGS},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    bad = cfg;
    switch (i) {
      case 0: bad.width = 0; break;
      case 1: bad.width = 70000; break;
      case 2: bad.scale_num = 2; bad.scale_den = 1; break;
      case 3: bad.scale_num = 0; break;
      case 4: bad.lambda = NAN; break;
      case 5: bad.lambda = 1.0; break;
      case 6: bad.lambda = 0.0; break;
      case 7: bad.scaling = RF_SCALING_FIXED; bad.k_d = -1; break;
      case 8: bad.scaling = RF_SCALING_FIXED; bad.k_c = NAN; break;
      case 9: bad.scaling = RF_SCALING_FIXED; bad.k_d = 65536; break;
      case 10: bad.scaling = 7; break;
      case 11: bad.variant = 9; break;
      case 12: bad.tile_width = w + 1; break;
      case 13: bad.flags = 0x80; break;
    }
    size_t b = 0;
    uint8_t mem[64];
    rf_engine *e = NULL;
    check_status(rf_workspace_size(&bad, &b), cases[i].want, cases[i].what);
    check_status(rf_init(mem, sizeof mem, &bad, &e), cases[i].want, cases[i].what);
    check(e == NULL, "no handle from a refused rf_init", cases[i].what);
  }

  uint8_t *mem = malloc(bytes);
  rf_engine *e = NULL;
  check_status(rf_init(NULL, bytes, &cfg, &e), RF_ERR_NULL_POINTER, "rf_init(NULL memory)");
  check_status(rf_init(mem, bytes, NULL, &e), RF_ERR_NULL_POINTER, "rf_init(NULL config)");
  check_status(rf_init(mem, bytes, &cfg, NULL), RF_ERR_NULL_POINTER, "rf_init(NULL handle)");
  check_status(rf_init(mem, bytes - 8, &cfg, &e), RF_ERR_BUFFER_TOO_SHORT, "rf_init: short memory");
  check_status(rf_init(mem, bytes, &cfg, &e), RF_OK, "rf_init");

  frame_out f = frame_alloc(n);
  rf_outputs out = outputs_of(&f), o;
  check_status(rf_represent(NULL, p.prev, p.next, n, 0, &out), RF_ERR_NULL_POINTER, "NULL engine");
  uint64_t zeros[64] = {0};
  check_status(rf_represent((rf_engine *)zeros, p.prev, p.next, n, 0, &out), RF_ERR_BAD_HANDLE,
               "a block rf_init never saw");
  check_status(rf_represent(e, NULL, p.next, n, 0, &out), RF_ERR_NULL_POINTER, "NULL prev");
  check_status(rf_represent(e, p.prev, p.next, n, 0, NULL), RF_ERR_NULL_POINTER, "NULL outputs");
  check_status(rf_represent(e, p.prev, p.next, n - 1, 0, &out), RF_ERR_BUFFER_TOO_SHORT,
               "frame shorter than w*h");
  check_status(rf_represent(e, p.prev, p.next, n, w - 1, &out), RF_ERR_STRIDE_TOO_SMALL,
               "stride below the width");
  check_status(rf_represent(e, p.prev, p.next, n, w + 1, &out), RF_ERR_BUFFER_TOO_SHORT,
               "frame too short for its stride");
  o = out;
  o.rgb_len = 3 * n - 1;
  memset(f.rgb, 0xAB, 3 * n);
  check_status(rf_represent(e, p.prev, p.next, n, 0, &o), RF_ERR_BUFFER_TOO_SHORT, "short rgb");
  check(f.rgb[0] == 0xAB && f.rgb[3 * n - 2] == 0xAB, "a refused call writes nothing", NULL);
  o = out;
  o.m_d_len = n - 1;
  check_status(rf_represent(e, p.prev, p.next, n, 0, &o), RF_ERR_BUFFER_TOO_SHORT, "short m_d");
  o = out;
  o.v_c = (float *)((char *)f.v_c + 1);
  o.v_c_len = 2 * n - 2;
  check_status(rf_represent(e, p.prev, p.next, n, 0, &o), RF_ERR_MISALIGNED, "misaligned v_c");
  check_status(rf_represent_rows(e, p.prev, p.next, n, 0, NULL, NULL), RF_ERR_NULL_POINTER,
               "NULL row callback");
  rf_engine *reentry[2] = {e, e};
  check_status(rf_represent_rows(e, p.prev, p.next, n, 0, calls_back_into_the_engine, reentry),
               RF_OK, "a callback calling the engine");
  check(reentry[1] == e, "the engine refuses a call from its own callback with RF_ERR_BUSY", NULL);

  /* Streams. */
  check_status(rf_stream_push(e, p.prev, p.next, w, collect, NULL), RF_ERR_NO_STREAM,
               "push without a stream");
  check_status(rf_stream_begin(e), RF_ERR_STREAM_NEEDS_KNOWN_SCALE, "stream with per-frame min-max");
  free(mem);
  cfg.scaling = RF_SCALING_FIXED;
  rf_workspace_size(&cfg, &bytes);
  mem = malloc(bytes);
  check_status(rf_init(mem, bytes, &cfg, &e), RF_OK, "rf_init (fixed)");
  check_status(rf_stream_begin(e), RF_OK, "rf_stream_begin");
  check_status(rf_stream_begin(e), RF_ERR_STREAM_ACTIVE, "a second rf_stream_begin");
  check_status(rf_represent(e, p.prev, p.next, n, 0, &out), RF_ERR_STREAM_ACTIVE,
               "rf_represent during a stream");
  row_collector sink = {w, f.rgb, f.m_c, f.m_d, f.v_c, f.v_d, 0, 0, 0};
  check_status(rf_stream_push(e, p.prev, p.next, w - 1, collect, &sink), RF_ERR_BUFFER_TOO_SHORT,
               "short row");
  check_status(rf_stream_push(e, p.prev, NULL, w, collect, &sink), RF_ERR_NULL_POINTER, "NULL row");
  check_status(rf_stream_push(e, p.prev, p.next, w, NULL, NULL), RF_ERR_NULL_POINTER,
               "NULL stream callback");
  check_status(rf_stream_cancel(e), RF_OK, "rf_stream_cancel");
  check_status(rf_represent(e, p.prev, p.next, n, 0, &out), RF_OK, "rf_represent after a cancel");
  rf_config narrow = cfg;
  narrow.tile_width = 16;
  size_t nb = 0;
  rf_workspace_size(&narrow, &nb);
  check(nb < bytes, "narrow tiles need less memory", NULL);
  uint8_t *nmem = malloc(nb);
  rf_engine *ne = NULL;
  check_status(rf_init(nmem, nb, &narrow, &ne), RF_OK, "rf_init (16-px tiles)");
  check_status(rf_stream_begin(ne), RF_ERR_STREAM_NEEDS_FULL_WIDTH, "stream with narrow tiles");

  /* Cues. */
  rf_cue_params cp;
  check_status(rf_cue_params_init(NULL), RF_ERR_NULL_POINTER, "rf_cue_params_init(NULL)");
  rf_cue_params_init(&cp);
  size_t cb = 0;
  check_status(rf_cues_size(&cfg, &cb), RF_OK, "rf_cues_size");
  uint8_t *cmem = malloc(cb);
  rf_cues *cues = NULL;
  rf_cue_params badp = cp;
  badp.level = -1;
  check_status(rf_cues_init(cmem, cb, &cfg, &badp, &cues), RF_ERR_BAD_CUE_PARAMS, "cue level -1");
  badp = cp;
  badp.threshold = 5;
  check_status(rf_cues_init(cmem, cb, &cfg, &badp, &cues), RF_ERR_BAD_CUE_PARAMS, "cue threshold 5");
  badp = cp;
  badp.smoothing = 64;
  check_status(rf_cues_init(cmem, cb, &cfg, &badp, &cues), RF_ERR_BAD_CUE_PARAMS, "smoothing 64");
  check_status(rf_cues_init(cmem, cb - 8, &cfg, &cp, &cues), RF_ERR_BUFFER_TOO_SHORT,
               "short cue memory");
  cp.level = 0.05;
  check_status(rf_cues_init(cmem, cb, &cfg, &cp, &cues), RF_OK, "rf_cues_init");
  rf_config big = cfg;
  big.width = 3000;
  check_status(rf_cues_size(&big, &cb), RF_ERR_CUES_FRAME_TOO_LARGE, "cues for 3000 px");
  check_status(rf_attach_cues(ne, cues), RF_OK, "cues on a narrow-tile engine of the same size");
  rf_config other = cfg;
  other.height = h + 1;
  size_t ob = 0;
  rf_workspace_size(&other, &ob);
  uint8_t *omem = malloc(ob);
  rf_engine *oe = NULL;
  rf_init(omem, ob, &other, &oe);
  check_status(rf_attach_cues(oe, cues), RF_ERR_SIZE_MISMATCH, "cues of another size");
  check_status(rf_attach_cues(e, (rf_cues *)zeros), RF_ERR_BAD_HANDLE, "not a cue handle");
  check_status(rf_attach_cues(e, cues), RF_OK, "rf_attach_cues");
  check_status(rf_represent(e, p.prev, p.next, n, 0, &out), RF_OK, "represent with cues");
  rf_region regions[RF_MAX_REGIONS];
  size_t count = 99;
  rf_cue_frame frame;
  check_status(rf_cues_result(cues, regions, RF_MAX_REGIONS, NULL, &frame), RF_ERR_NULL_POINTER,
               "NULL count");
  check_status(rf_cues_result(cues, regions, RF_MAX_REGIONS, &count, &frame), RF_OK,
               "rf_cues_result");
  check(frame.frames == 1 && frame.pixels == n, "the cues saw one frame of every pixel", NULL);
  check(count >= 1 && count == frame.regions_kept, "the moving texture gives a region", NULL);
  /* Streaming into the same cues gives the same regions. */
  rf_region whole[RF_MAX_REGIONS];
  memcpy(whole, regions, sizeof whole);
  size_t whole_count = count;
  check_status(rf_cues_reset(cues), RF_OK, "rf_cues_reset");
  check_status(rf_stream_begin(e), RF_OK, "stream with cues");
  check_status(rf_attach_cues(e, NULL), RF_ERR_STREAM_ACTIVE, "detach during a stream");
  for (uint32_t y = 0; y < h; y++) rf_stream_push(e, p.prev + y * w, p.next + y * w, w, collect, &sink);
  rf_cues_result(cues, regions, RF_MAX_REGIONS, &count, &frame);
  check(count == whole_count && memcmp(regions, whole, count * sizeof regions[0]) == 0,
        "streamed cues equal whole-frame cues", NULL);
  check_status(rf_attach_cues(e, NULL), RF_OK, "detach");

  /* Versions and messages. */
  check(rf_abi_version() == RF_ABI_VERSION, "rf_abi_version matches the header", NULL);
  char version[32];
  snprintf(version, sizeof version, "%d.%d.%d", RF_VERSION_MAJOR, RF_VERSION_MINOR,
           RF_VERSION_PATCH);
  check(strcmp(rf_version(), version) == 0, "rf_version matches the header", rf_version());
  check(strcmp(rf_strerror(RF_OK), "success") == 0, "rf_strerror(RF_OK)", NULL);
  check(strstr(rf_strerror(-5), "unknown") != NULL, "rf_strerror of an unknown code", NULL);
  for (int s = 0; s <= RF_ERR_BUSY; s++) check(strlen(rf_strerror(s)) > 5, "a message per code", NULL);

  frame_free(&f);
  free(mem);
  free(nmem);
  free(cmem);
  free(omem);
  free(p.prev);
  free(p.next);
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: %s VECTORS_DIR GOLDEN_SUMMARY\n", argv[0]);
    return 2;
  }
  golden(argv[1], argv[2]);
  rows_and_streams();
  statuses();
  printf("capi: %d passed, %d failed\n", passed, failed);
  return failed ? 1 : 0;
}
