/*
 * represent: the ReynoldsFlow representation of one frame pair, from C.
 *
 *   represent PREV.pgm NEXT.pgm OUT.ppm [--scale minmax|fixed:KD,KC]
 *             [--intensity-scale S] [--lambda L]
 *
 * Reads two binary 8-bit PGMs (P5) of one size and writes a binary PPM (P6)
 * whose pixels are `reynoldsflow pair PREV NEXT`'s rep.png with the same
 * flags. On bad input it prints why on stderr, exits with status 1 and
 * leaves no output file (the PPM is written to OUT.ppm.tmp, then renamed).
 * Build: make -C capi/examples (README, "C").
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "reynoldsflow.h"

static const char *usage =
    "usage: represent PREV.pgm NEXT.pgm OUT.ppm [--scale minmax|fixed:KD,KC] "
    "[--intensity-scale S] [--lambda L]\n";

static int fail(const char *what, const char *why) {
  fprintf(stderr, "represent: error: %s: %s\n", what, why);
  return 1;
}

/* A binary PGM with maxval 255 (header comments allowed), or NULL with *why set. */
static uint8_t *read_pgm(const char *path, uint32_t *w, uint32_t *h, const char **why) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    *why = strerror(errno);
    return NULL;
  }
  unsigned long v[3] = {0, 0, 0};
  int ok = fgetc(f) == 'P' && fgetc(f) == '5';
  for (int i = 0; ok && i < 3; i++) {
    int c = fgetc(f);
    while (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '#') {
      if (c == '#')
        while (c != '\n' && c != EOF) c = fgetc(f);
      c = fgetc(f);
    }
    if (c < '0' || c > '9') ok = 0;
    while (ok && c >= '0' && c <= '9') {
      v[i] = v[i] * 10 + (unsigned long)(c - '0');
      if (v[i] > 65535) ok = 0;
      c = fgetc(f);
    }
    /* One whitespace byte ends the header. */
    if (ok && i == 2 && c != ' ' && c != '\t' && c != '\r' && c != '\n') ok = 0;
  }
  if (!ok || v[0] == 0 || v[1] == 0 || v[2] != 255) {
    fclose(f);
    *why = "not a binary 8-bit PGM (P5, maxval 255, sides 1 to 65535)";
    return NULL;
  }
  size_t n = (size_t)v[0] * v[1];
  uint8_t *pixels = malloc(n);
  if (!pixels || fread(pixels, 1, n, f) != n) {
    free(pixels);
    fclose(f);
    *why = pixels ? "the file ends before its pixels do" : "out of memory";
    return NULL;
  }
  fclose(f);
  *w = (uint32_t)v[0];
  *h = (uint32_t)v[1];
  return pixels;
}

static uint64_t gcd(uint64_t a, uint64_t b) {
  while (b) {
    uint64_t t = a % b;
    a = b;
    b = t;
  }
  return a;
}

/* A non-negative decimal ("12", "0.5", ".25") as an exact reduced fraction. */
static int parse_decimal(const char *s, const char *end, uint64_t *num, uint64_t *den) {
  uint64_t n = 0, d = 1;
  int digits = 0, point = 0;
  for (; s < end; s++) {
    if (*s == '.' && !point) {
      point = 1;
    } else if (*s >= '0' && *s <= '9') {
      if (n > (UINT64_MAX - 9) / 10 || (point && d > UINT64_MAX / 10)) return 0;
      n = n * 10 + (uint64_t)(*s - '0');
      if (point) d *= 10;
      digits++;
    } else {
      return 0;
    }
  }
  if (!digits) return 0;
  uint64_t g = gcd(n, d);
  *num = n / g;
  *den = d / g;
  return 1;
}

/* The intensity scale as `reynoldsflow --intensity-scale` reads it: N/D or a
 * decimal, exact, reduced to 32-bit integers. */
static int parse_ratio(const char *s, uint32_t *num, uint32_t *den) {
  const char *slash = strchr(s, '/'), *end = s + strlen(s);
  uint64_t n1, d1, n2 = 1, d2 = 1;
  if (!parse_decimal(s, slash ? slash : end, &n1, &d1)) return 0;
  if (slash && (!parse_decimal(slash + 1, end, &n2, &d2) || n2 == 0)) return 0;
  /* (n1 / d1) / (n2 / d2) = (n1 d2) / (d1 n2) */
  if ((d2 && n1 > UINT64_MAX / d2) || (n2 && d1 > UINT64_MAX / n2)) return 0;
  uint64_t n = n1 * d2, d = d1 * n2, g = gcd(n, d);
  if (g == 0) g = 1;
  n /= g;
  d /= g;
  if (n > UINT32_MAX || d > UINT32_MAX) return 0;
  *num = (uint32_t)n;
  *den = (uint32_t)d;
  return 1;
}

/* A finite, non-negative number spanning the whole string (above 0 if `positive`). */
static int parse_number(const char *s, int positive, double *out) {
  char *end;
  errno = 0;
  double v = strtod(s, &end);
  if (errno || end == s || *end || !isfinite(v) || v < 0 || (positive && v == 0)) return 0;
  *out = v;
  return 1;
}

int main(int argc, char **argv) {
  if (argc < 4) {
    fputs(usage, stderr);
    return 1;
  }
  const char *prev_path = argv[1], *next_path = argv[2], *out_path = argv[3];
  const char *scale = "minmax", *intensity = NULL, *lambda = NULL;
  for (int i = 4; i < argc; i++) {
    const char **slot = strcmp(argv[i], "--scale") == 0             ? &scale
                        : strcmp(argv[i], "--intensity-scale") == 0 ? &intensity
                        : strcmp(argv[i], "--lambda") == 0          ? &lambda
                                                                    : NULL;
    if (!slot || i + 1 == argc) {
      fprintf(stderr, "represent: error: %s: %s\n%s", argv[i],
              slot ? "needs a value" : "unknown option", usage);
      return 1;
    }
    *slot = argv[++i];
  }

  uint32_t w, h, w2, h2;
  const char *why;
  uint8_t *prev = read_pgm(prev_path, &w, &h, &why);
  if (!prev) return fail(prev_path, why);
  uint8_t *next = read_pgm(next_path, &w2, &h2, &why);
  if (!next) return fail(next_path, why);
  if (w != w2 || h != h2) return fail(next_path, "the frames differ in size");

  rf_config cfg;
  rf_config_init(&cfg, w, h);
  if (strcmp(scale, "minmax") != 0) {
    const char *comma = strchr(scale, ',');
    char kd[64];
    size_t kd_len = comma ? (size_t)(comma - scale) : 0;
    if (strncmp(scale, "fixed:", 6) != 0 || !comma || kd_len - 6 >= sizeof kd)
      return fail("--scale", "expected 'minmax' or 'fixed:KD,KC' (e.g. fixed:8,32)");
    memcpy(kd, scale + 6, kd_len - 6);
    kd[kd_len - 6] = '\0';
    if (!parse_number(kd, 0, &cfg.k_d) || !parse_number(comma + 1, 0, &cfg.k_c))
      return fail("--scale", "gains must be non-negative numbers (e.g. fixed:8,32)");
    cfg.scaling = RF_SCALING_FIXED;
  }
  if (intensity && !parse_ratio(intensity, &cfg.scale_num, &cfg.scale_den))
    return fail("--intensity-scale", "expected an exact ratio such as 1/255 or a decimal");
  if (lambda && !parse_number(lambda, 1, &cfg.lambda))
    return fail("--lambda", "expected a positive number (e.g. 1e-4)");

  size_t bytes;
  rf_status s = rf_workspace_size(&cfg, &bytes);
  if (s != RF_OK) return fail("settings", rf_strerror((int)s));
  void *memory = malloc(bytes);
  size_t n = (size_t)w * h;
  uint8_t *rgb = malloc(3 * n);
  if (!memory || !rgb) return fail("memory", "out of memory");
  rf_engine *engine;
  s = rf_init(memory, bytes, &cfg, &engine);
  rf_outputs out = {0};
  out.rgb = rgb;
  out.rgb_len = 3 * n;
  if (s == RF_OK) s = rf_represent(engine, prev, next, n, 0, &out);
  if (s != RF_OK) return fail("represent", rf_strerror((int)s));

  char tmp[4096];
  if (snprintf(tmp, sizeof tmp, "%s.tmp", out_path) >= (int)sizeof tmp)
    return fail(out_path, "path too long");
  FILE *f = fopen(tmp, "wb");
  if (!f) return fail(out_path, strerror(errno));
  int written = fprintf(f, "P6\n%u %u\n255\n", w, h) > 0 && fwrite(rgb, 1, 3 * n, f) == 3 * n;
  if (fclose(f) != 0 || !written || rename(tmp, out_path) != 0) {
    int e = errno;
    remove(tmp);
    return fail(out_path, strerror(e));
  }
  free(prev);
  free(next);
  free(rgb);
  free(memory);
  return 0;
}
