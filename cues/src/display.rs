//! Display helpers: what a small colour screen shows of a frame, one row at
//! a time, as raw RGB565 values (`u16`: red in bits 15–11, green in 10–5,
//! blue in 4–0; the layout of embedded-graphics' `Rgb565` and of the usual
//! SPI panels, so `Rgb565::from(RawU16::new(v))` converts without cost).
//! The core stays free of any graphics crate.
//!
//! Views ([`View`]): the gray frame, the representation `[|v_d|, |v_c|, fⁿ]`,
//! a field's magnitude as gray, and the colour wheel of a field: direction →
//! hue, magnitude → value. The hue uses `micromath`'s approximate `atan2`
//! (max error 0.16°, about 0.7 of the 1536 hue steps), called explicitly so
//! that tests on a host compute what a target computes; it is for display
//! only, never part of the bit-exact numerics.

use core::f32::consts::PI;

use micromath::F32Ext;

use reynoldsflow_core::{ByteScale, Config, Error, FlowPixel, Pixels, Sink, rgb};

use crate::Field;

/// Pack 8-bit red, green and blue into RGB565 by truncation (the top 5, 6
/// and 5 bits), as `Rgb565::new(r >> 3, g >> 2, b >> 3)` does.
#[inline(always)]
pub const fn rgb565(r: u8, g: u8, b: u8) -> u16 {
    ((r as u16 >> 3) << 11) | ((g as u16 >> 2) << 5) | (b as u16 >> 3)
}

/// Hue steps in a full turn: six sectors of 256.
pub const HUE_STEPS: u16 = 1536;

/// `x / 255` rounded to nearest, for `x ≤ 255²`.
#[inline(always)]
const fn div255(x: u32) -> u32 {
    (x + 127) / 255
}

/// Integer HSV → RGB8: `hue` in steps of a turn modulo [`HUE_STEPS`]
/// (0 red, 256 yellow, 512 green, 768 cyan, 1024 blue, 1280 magenta),
/// `saturation` and `value` in 0–255. Each channel is within 1 of the exact
/// float conversion, and the maximum channel is `value` exactly.
pub const fn hsv(hue: u16, saturation: u8, value: u8) -> [u8; 3] {
    let hue = hue % HUE_STEPS;
    let (sector, f) = (hue / 256, (hue % 256) as u32);
    let (s, v) = (saturation as u32, value as u32);
    let p = div255(v * (255 - s)) as u8;
    let q = div255(v * (255 - div255(s * f))) as u8;
    let t = div255(v * (255 - div255(s * (255 - f)))) as u8;
    let v = value;
    match sector {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// The hue of a direction (x right, y down, so angles turn clockwise on
/// screen): right is red (0), down yellow-green (384), left cyan (768), up
/// violet (1152). `round(atan2(y, x) · 1536 / 2π) mod 1536`, with micromath's
/// `atan2`; the zero vector is 0. Any finite vector, however long or short
/// (the components are first divided by the larger of their magnitudes, so
/// the `atan2` approximation's squares neither overflow nor vanish); a
/// non-finite component gives some hue, without a panic.
pub fn direction_hue(v: [f32; 2]) -> u16 {
    let [x, y] = v;
    let scale = x.abs().max(y.abs());
    if scale == 0.0 {
        return 0;
    }
    // The common scale cancels in the angle: the larger component becomes
    // ±1 exactly, the other rounds once (far finer than a hue step).
    let (x, y) = (x / scale, y / scale);
    let angle = F32Ext::atan2(y, x); // [-π, π]
    let steps = angle * (f32::from(HUE_STEPS) / (2.0 * PI));
    // Round half away from zero (no `f32::round` in `core`); `as` saturates
    // (and takes a NaN to 0).
    let steps = if steps >= 0.0 {
        steps + 0.5
    } else {
        steps - 0.5
    } as i32;
    steps.rem_euclid(i32::from(HUE_STEPS)) as u16
}

/// What a screen shows of a computed frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum View {
    /// The frame `fⁿ` in gray.
    Luma,
    /// The representation's RGB8 `[|v_d|, |v_c|, fⁿ]` (SPEC §4), with these
    /// byte scales (as [`rgb`]).
    Representation {
        /// Scale of `|v_d|` (R).
        scale_d: ByteScale,
        /// Scale of `|v_c|` (G).
        scale_c: ByteScale,
    },
    /// A field's magnitude in gray.
    Magnitude {
        /// The field.
        field: Field,
        /// Magnitude → gray level.
        scale: ByteScale,
    },
    /// The colour wheel of a field: direction → hue ([`direction_hue`]),
    /// magnitude → value, full saturation (still pixels are black).
    Direction {
        /// The field.
        field: Field,
        /// Magnitude → value.
        scale: ByteScale,
    },
}

impl View {
    /// The RGB8 colour of one pixel.
    #[inline]
    pub fn rgb8(&self, px: &FlowPixel) -> [u8; 3] {
        match *self {
            View::Luma => [px.luma; 3],
            View::Representation { scale_d, scale_c } => rgb(px, &scale_d, &scale_c),
            View::Magnitude { field, scale } => [scale.byte(field.magnitude(px)); 3],
            View::Direction { field, scale } => match scale.byte(field.magnitude(px)) {
                0 => [0; 3],
                value => hsv(direction_hue(field.vector(px)), 255, value),
            },
        }
    }

    /// The RGB565 value of one pixel.
    #[inline]
    pub fn rgb565(&self, px: &FlowPixel) -> u16 {
        let [r, g, b] = self.rgb8(px);
        rgb565(r, g, b)
    }

    /// A row (or any run) of pixels into RGB565; `out` and `pixels` are
    /// paired up to the shorter of the two.
    pub fn row565(&self, pixels: impl IntoIterator<Item = FlowPixel>, out: &mut [u16]) {
        for (dst, px) in out.iter_mut().zip(pixels) {
            *dst = self.rgb565(&px);
        }
    }

    /// Whether the view reads the fields (the direction wheel), not only
    /// the magnitudes and `fⁿ`.
    pub fn reads_fields(&self) -> bool {
        matches!(self, View::Direction { .. })
    }
}

/// A sink that writes one [`View`] of each pixel into a row-major RGB565
/// plane of `width · height` values (a frame buffer, or one panel of it).
#[derive(Debug)]
pub struct Rgb565Sink<'a> {
    plane: &'a mut [u16],
    width: usize,
    view: View,
}

impl<'a> Rgb565Sink<'a> {
    /// Check the plane's size against the frame.
    pub fn new(config: &Config, plane: &'a mut [u16], view: View) -> Result<Self, Error> {
        let needed = config.width() * config.height();
        if plane.len() < needed {
            return Err(Error::BufferTooShort {
                needed,
                got: plane.len(),
            });
        }
        Ok(Self {
            plane,
            width: config.width(),
            view,
        })
    }

    /// Change the view (e.g. a new scale for the next frame).
    pub fn set_view(&mut self, view: View) {
        self.view = view;
    }
}

impl Sink for Rgb565Sink<'_> {
    fn reads_fields(&self) -> bool {
        self.view.reads_fields()
    }

    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let start = y * self.width + x;
        if let Some(out) = self.plane.get_mut(start..start + pixels.len()) {
            self.view.row565(pixels.iter(), out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rows::Rows;
    use fixed::types::U16F16;

    fn exact_hsv(hue: f64, s: f64, v: f64) -> [f64; 3] {
        let h = hue / 256.0;
        let c = v * s;
        let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
        let m = v - c;
        let (r, g, b) = match h as u32 {
            0 => (c, x, 0.0),
            1 => (x, c, 0.0),
            2 => (0.0, c, x),
            3 => (0.0, x, c),
            4 => (x, 0.0, c),
            _ => (c, 0.0, x),
        };
        [r + m, g + m, b + m]
    }

    #[test]
    fn rgb565_packs_like_embedded_graphics() {
        assert_eq!(rgb565(255, 255, 255), 0xFFFF);
        assert_eq!(rgb565(0, 0, 0), 0);
        assert_eq!(rgb565(255, 0, 0), 0xF800);
        assert_eq!(rgb565(0, 255, 0), 0x07E0);
        assert_eq!(rgb565(0, 0, 255), 0x001F);
        assert_eq!(
            rgb565(0x12, 0x34, 0x56),
            (0x12 >> 3) << 11 | (0x34 >> 2) << 5 | 0x56 >> 3
        );
    }

    #[test]
    fn hsv_is_within_one_level_of_float() {
        for hue in (0..HUE_STEPS).step_by(7) {
            for s in [0u8, 1, 100, 254, 255] {
                for v in [0u8, 1, 128, 255] {
                    let got = hsv(hue, s, v);
                    let want = exact_hsv(f64::from(hue), f64::from(s) / 255.0, f64::from(v));
                    for c in 0..3 {
                        assert!(
                            (f64::from(got[c]) - want[c]).abs() <= 1.0,
                            "hue {hue} s {s} v {v}: {got:?} vs {want:?}"
                        );
                    }
                    assert_eq!(*got.iter().max().unwrap(), v);
                }
            }
        }
        assert_eq!(hsv(0, 255, 255), [255, 0, 0]);
        assert_eq!(hsv(512, 255, 255), [0, 255, 0]);
        assert_eq!(hsv(1024, 255, 255), [0, 0, 255]);
        assert_eq!(hsv(HUE_STEPS, 255, 200), hsv(0, 255, 200));
    }

    #[test]
    fn hue_follows_direction_within_a_step() {
        let v = |x: f64, y: f64| [x as f32, y as f32];
        assert_eq!(direction_hue(v(1.0, 0.0)), 0);
        assert_eq!(direction_hue(v(0.0, 2.5)), 384);
        assert_eq!(direction_hue(v(-0.01, 0.0)), 768);
        assert_eq!(direction_hue(v(0.0, -3.0)), 1152);
        assert_eq!(direction_hue(v(0.0, 0.0)), 0);
        for k in 0..360 {
            let a = f64::from(k) * core::f64::consts::PI / 180.0 + 0.001;
            let got = f64::from(direction_hue(v(7.0 * a.cos(), 7.0 * a.sin())));
            let want = a / (2.0 * core::f64::consts::PI) * 1536.0;
            let diff = (got - want).rem_euclid(1536.0);
            assert!(diff.min(1536.0 - diff) <= 1.5, "{k}°: {got} vs {want}");
        }
        // Extreme components do not break it: the direction of a vector
        // is that of any multiple of it, from subnormal to f32::MAX.
        let tiny = f32::from_bits(1); // 2⁻¹⁴⁹
        for scale in [tiny, 1e-30, 2f32.powi(-92), 1e-6, 1.0, 3e4, 1e30, f32::MAX] {
            let hue = |x: f32, y: f32| direction_hue([x * scale, y * scale]);
            assert_eq!(hue(1.0, 0.0), 0, "{scale}");
            assert_eq!(hue(0.0, 1.0), 384, "{scale}");
            assert_eq!(hue(-1.0, 0.0), 768, "{scale}");
            assert_eq!(hue(0.0, -1.0), 1152, "{scale}");
            assert_eq!(hue(-1.0, -1.0), 960, "{scale}"); // up-left: 1536 · 5/8
        }
        assert_eq!(direction_hue([f32::MAX, tiny]), 0);
        assert_eq!(direction_hue([-tiny, f32::MIN]), 1152);
        // Not from the engine, but no panic and a hue in range.
        for v in [
            [f32::NAN, 1.0],
            [f32::INFINITY, 1.0],
            [f32::NEG_INFINITY, f32::NAN],
        ] {
            assert!(direction_hue(v) < HUE_STEPS, "{v:?}");
        }
    }

    #[test]
    fn views_of_a_pixel() {
        let px = FlowPixel {
            v_c: [-2.0, 0.0],
            v_d: [0.0, -1.0],
            m_c: 2.0,
            m_d: 1.0,
            luma: 77,
        };
        let k = |k: f64| ByteScale::fixed(U16F16::from_num(k));
        assert_eq!(View::Luma.rgb8(&px), [77; 3]);
        let repr = View::Representation {
            scale_d: k(100.0),
            scale_c: k(10.0),
        };
        assert_eq!(repr.rgb8(&px), [100, 20, 77]);
        assert_eq!(repr.rgb565(&px), rgb565(100, 20, 77));
        let mag = View::Magnitude {
            field: Field::CurlFree,
            scale: k(100.0),
        };
        assert_eq!(mag.rgb8(&px), [200; 3]);
        // v_c points left: cyan; v_d points up: violet.
        let dir_c = View::Direction {
            field: Field::CurlFree,
            scale: k(100.0),
        };
        assert_eq!(dir_c.rgb8(&px), [0, 200, 200]);
        let dir_d = View::Direction {
            field: Field::DivergenceFree,
            scale: k(255.0),
        };
        assert_eq!(dir_d.rgb8(&px), hsv(1152, 255, 255));
        let still = FlowPixel::default();
        assert_eq!(dir_d.rgb8(&still), [0; 3]);
    }

    #[test]
    fn the_sink_fills_a_plane() {
        let config = Config::new(4, 3, reynoldsflow_core::Params::DEFAULT).unwrap();
        let mut small = [0u16; 11];
        assert_eq!(
            Rgb565Sink::new(&config, &mut small, View::Luma).err(),
            Some(Error::BufferTooShort {
                needed: 12,
                got: 11
            })
        );
        let mut plane = [0u16; 12];
        let mut sink = Rgb565Sink::new(&config, &mut plane, View::Luma).unwrap();
        let px = |l| FlowPixel {
            luma: l,
            ..FlowPixel::default()
        };
        sink.row(1, 1, Rows::of(&[px(255), px(8)]).pixels());
        // Runs past the frame: ignored.
        sink.row(2, 3, Rows::of(&[px(255), px(255)]).pixels());
        assert_eq!(plane[5], 0xFFFF);
        assert_eq!(plane[6], rgb565(8, 8, 8));
        assert_eq!(plane.iter().filter(|&&v| v != 0).count(), 2);
    }
}
