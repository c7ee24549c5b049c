/* The ReynoldsFlow C API on an emulated board: the pair in flash through
 * rf_represent_rows into a row callback that compares each row with the
 * host's bytes and writes it to a file over semihosting. Instructions are
 * counted between bench_start and bench_stop (the callback steps out of the
 * window), as in the Rust firmware (examples/firmware), so the two counts
 * compare the C call path with the Rust one. Exit status: 0 identical,
 * 1 different, 2 refused by the library, 3 output file, 4 incomplete. */
#include <stdint.h>
#include <string.h>

#include "reynoldsflow.h"
#include "semihost.h"

#ifndef WIDTH
#error "WIDTH, HEIGHT, TILE_WIDTH and BOARD come from the Makefile"
#endif
#define TEXT(x) #x
#define DECIMAL(x) TEXT(x)
#define SIZE DECIMAL(WIDTH) "x" DECIMAL(HEIGHT)

extern const uint8_t rf_prev[], rf_next[], rf_expected[];
extern uint32_t _ebss;

/* The engine's working memory: a static array, sized at compile time. */
static uint8_t workspace[RF_WORKSPACE_BYTES(TILE_WIDTH, 0)];

/* Distinct volatile stores, so neither marker is optimised away or folded. */
static volatile uint32_t bench;
__attribute__((noinline)) void bench_start(void) { bench = 1; }
__attribute__((noinline)) void bench_stop(void) { bench = 2; }

typedef struct {
  int fd;
  uint32_t pixels, mismatched, first_x, first_y;
  int io_failed;
} harness;

/* Outside the measured window: comparison and file I/O are not the computation. */
static void emit_row(void *user, const rf_row *row) {
  bench_stop();
  harness *h = user;
  uint32_t offset = 3 * (row->y * WIDTH + row->x);
  for (uint32_t i = 0; i < row->width; i++) {
    if (memcmp(row->rgb + 3 * i, rf_expected + offset + 3 * i, 3) != 0) {
      if (h->mismatched++ == 0) {
        h->first_x = row->x + i;
        h->first_y = row->y;
      }
    }
  }
  h->pixels += row->width;
  h->io_failed |= sh_write_at(h->fd, offset, row->rgb, 3 * (size_t)row->width);
  bench_start();
}

/* Stack high-water mark: paint below this frame, find the deepest change. */
#define PATTERN 0x5AC396E1u
static uint32_t *painted_low;
__attribute__((noinline)) static void paint_stack(void) {
  uint32_t here = 0, *sp = (uint32_t *)((uintptr_t)&here & ~3u) - 64;
  uint32_t *low = &_ebss;
  if (sp - low > 16384) low = sp - 16384; /* 64 KiB is plenty, and quick */
  painted_low = low;
  for (volatile uint32_t *p = low; p < sp; p++) *p = PATTERN;
}

static uint32_t stack_used(int *saturated) {
  extern uint32_t _stack_top;
  uint32_t *p = painted_low;
  while (p < &_stack_top && *p == PATTERN) p++;
  *saturated = p == painted_low;
  return (uint32_t)((char *)&_stack_top - (char *)p);
}

int main(void) {
  rf_config cfg;
  rf_config_init(&cfg, WIDTH, HEIGHT);
  cfg.scaling = RF_SCALING_FIXED; /* the Rust firmware's gains */
  cfg.k_d = 8;
  cfg.k_c = 32;
  cfg.tile_width = TILE_WIDTH;
  size_t need = 0;
  rf_engine *engine = 0;
  rf_status s = rf_workspace_size(&cfg, &need);
  if (s == RF_OK) s = rf_init(workspace, sizeof workspace, &cfg, &engine);
  sh_puts("board=" BOARD " lang=c ");
  sh_puts("size=" SIZE " ");
  sh_put_field("tile", TILE_WIDTH, ' ');
  sh_put_field("workspace_bytes", (uint32_t)need, ' ');
  sh_put_field("abi", rf_abi_version(), '\n');
  if (s != RF_OK) {
    sh_puts("the library refused the setup: ");
    sh_puts(rf_strerror((int)s));
    sh_puts("\n");
    return 2;
  }
  harness h = {sh_create("rgb-" BOARD "-c.bin"), 0, 0, 0, 0, 0};
  if (h.fd < 0) {
    sh_puts("cannot create the output file\n");
    return 3;
  }
  paint_stack();
  bench_start();
  s = rf_represent_rows(engine, rf_prev, rf_next, (size_t)WIDTH * HEIGHT, 0, emit_row, &h);
  bench_stop();
  int saturated;
  uint32_t stack = stack_used(&saturated);
  sh_close(h.fd);
  sh_puts("result ");
  sh_put_field("pixels", h.pixels, ' ');
  sh_put_field("mismatched", h.mismatched, ' ');
  sh_put_field("stack", stack, ' ');
  sh_puts(saturated ? "stack_saturated=true\n" : "stack_saturated=false\n");
  if (s != RF_OK) {
    sh_puts(rf_strerror((int)s));
    sh_puts("\n");
    return 2;
  }
  if (h.mismatched) {
    sh_put_field("first mismatch at x", h.first_x, ' ');
    sh_put_field("y", h.first_y, '\n');
    return 1;
  }
  if (h.io_failed) return 3;
  if (h.pixels != (uint32_t)WIDTH * HEIGHT) return 4;
  sh_puts("identical to the host's bytes\n");
  return 0;
}
