//! The dashboard, drawn with embedded-graphics on any `DrawTarget<Color =
//! Rgb565>` of at least 320 × 240: the simulator's display here, an SPI
//! panel's driver on a board. No allocation: text is formatted into
//! `heapless` strings, images stream from borrowed RGB565 planes.
//!
//! ```text
//! +----------------------+----------------------+
//! | frame + cue boxes    | representation       |
//! |                      | [|v_d|, |v_c|, f]    |
//! +----------------------+----------------------+
//! | direction of v_c     | cue #1 zoomed 4x     |
//! | (hue) and |v_c|      | and the cue list     |
//! +----------------------+----------------------+
//! ```

use core::fmt::Write;

use embedded_graphics::mono_font::ascii::{FONT_4X6, FONT_5X8};
use embedded_graphics::mono_font::{MonoTextStyle, MonoTextStyleBuilder};
use embedded_graphics::pixelcolor::raw::RawU16;
use embedded_graphics::pixelcolor::{Rgb565, WebColors};
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::{PrimitiveStyle, Rectangle};
use embedded_graphics::text::{Baseline, Text};
use heapless::String;
use reynoldsflow_core::fixed::types::U32F32;
use reynoldsflow_cues::Region;

/// Panel size: each view of the frame is drawn 1:1 in one quarter.
pub const PANEL: Size = Size::new(160, 120);

/// The whole dashboard.
pub const SCREEN: Size = Size::new(320, 240);

/// Box colour of cue `i` (strongest first): none of them gray, so a box
/// stands out on the gray frame (the tests look for the first one there).
pub const CUE_COLORS: [Rgb565; 4] = [
    Rgb565::MAGENTA,
    Rgb565::YELLOW,
    Rgb565::CYAN,
    Rgb565::CSS_ORANGE,
];

/// Zoom of the inset around the strongest cue.
const ZOOM: u32 = 4;
/// Source window of the inset, px.
const INSET: Size = Size::new(36, 18);

/// Everything one dashboard shows, borrowed.
#[derive(Clone, Copy, Debug)]
pub struct Dashboard<'a> {
    /// Frame number shown.
    pub index: usize,
    /// The gray frame, RGB565, `PANEL` row-major.
    pub frame: &'a [u16],
    /// The representation, RGB565.
    pub representation: &'a [u16],
    /// The direction view, RGB565.
    pub direction: &'a [u16],
    /// The motion cues, strongest first.
    pub regions: &'a [Region],
    /// The level the cues were thresholded at, px.
    pub level: U32F32,
    /// Regions found (kept or not).
    pub found: u32,
}

fn color(raw: u16) -> Rgb565 {
    Rgb565::from(RawU16::new(raw))
}

fn label(color: Rgb565) -> MonoTextStyle<'static, Rgb565> {
    MonoTextStyleBuilder::new()
        .font(&FONT_5X8)
        .text_color(color)
        .background_color(Rgb565::BLACK)
        .build()
}

/// A `PANEL`-sized RGB565 plane at `origin` (missing values are black).
fn blit<D>(target: &mut D, origin: Point, plane: &[u16]) -> Result<(), D::Error>
where
    D: DrawTarget<Color = Rgb565>,
{
    let area = Rectangle::new(origin, PANEL);
    let n = (PANEL.width * PANEL.height) as usize;
    let colors = plane
        .iter()
        .copied()
        .chain(core::iter::repeat(0))
        .take(n)
        .map(color);
    target.fill_contiguous(&area, colors)
}

/// The box of a cue, one pixel outside the moving pixels so they stay
/// visible, with its rank beside it.
fn draw_cue<D>(target: &mut D, rank: usize, region: &Region, color: Rgb565) -> Result<(), D::Error>
where
    D: DrawTarget<Color = Rgb565>,
{
    let corner = Point::new(i32::from(region.x_min) - 1, i32::from(region.y_min) - 1);
    let size = Size::new(
        u32::from(region.width()) + 2,
        u32::from(region.height()) + 2,
    );
    Rectangle::new(corner, size)
        .into_styled(PrimitiveStyle::with_stroke(color, 1))
        .draw(target)?;
    let mut text: String<4> = String::new();
    let _ = write!(text, "{}", rank + 1);
    let style = MonoTextStyle::new(&FONT_4X6, color);
    let at = Point::new(i32::from(region.x_max) + 3, i32::from(region.y_min) - 2);
    Text::with_baseline(&text, at, style, Baseline::Top).draw(target)?;
    Ok(())
}

/// Draw the dashboard at the target's origin.
pub fn draw_dashboard<D>(target: &mut D, dash: &Dashboard<'_>) -> Result<(), D::Error>
where
    D: DrawTarget<Color = Rgb565>,
{
    let (pw, ph) = (PANEL.width as i32, PANEL.height as i32);
    let origins = [
        Point::zero(),
        Point::new(pw, 0),
        Point::new(0, ph),
        Point::new(pw, ph),
    ];
    // Frame with the cue boxes.
    blit(target, origins[0], dash.frame)?;
    {
        let mut panel = target.cropped(&Rectangle::new(origins[0], PANEL));
        for (rank, (region, &c)) in dash.regions.iter().zip(&CUE_COLORS).enumerate() {
            draw_cue(&mut panel, rank, region, c)?;
        }
    }
    blit(target, origins[1], dash.representation)?;
    blit(target, origins[2], dash.direction)?;
    // Inset and list.
    Rectangle::new(origins[3], PANEL)
        .into_styled(PrimitiveStyle::with_fill(Rgb565::BLACK))
        .draw(target)?;
    draw_inset(target, origins[3] + Point::new(8, 12), dash)?;

    // Panel titles.
    let white = label(Rgb565::WHITE);
    let mut title: String<24> = String::new();
    let _ = write!(title, "frame {}", dash.index);
    let titles: [&str; 4] = [&title, "[|vd| |vc| f]", "vc direction", "cue 1 x4"];
    for (origin, text) in origins.iter().zip(titles) {
        Text::with_baseline(text, *origin + Point::new(1, 1), white, Baseline::Top).draw(target)?;
    }
    // The cue list.
    let mut y = origins[3].y + 12 + (INSET.height * ZOOM) as i32 + 2;
    for (rank, (r, &c)) in dash.regions.iter().zip(&CUE_COLORS).take(3).enumerate() {
        let mut line: String<40> = String::new();
        let _ = write!(
            line,
            "{} {},{} {}x{} pk {:.2}",
            rank + 1,
            r.x_min,
            r.y_min,
            r.width(),
            r.height(),
            r.peak
        );
        Text::with_baseline(
            &line,
            Point::new(origins[3].x + 2, y),
            label(c),
            Baseline::Top,
        )
        .draw(target)?;
        y += 9;
    }
    if dash.regions.is_empty() {
        Text::with_baseline(
            "no motion cue",
            Point::new(origins[3].x + 2, y),
            white,
            Baseline::Top,
        )
        .draw(target)?;
        y += 9;
    }
    let mut line: String<40> = String::new();
    let _ = write!(line, "level {:.2} found {}", dash.level, dash.found);
    let gray = label(Rgb565::CSS_LIGHT_GRAY);
    Text::with_baseline(&line, Point::new(origins[3].x + 2, y), gray, Baseline::Top)
        .draw(target)?;
    Ok(())
}

/// The frame around the strongest cue, magnified `ZOOM` times, with its box.
fn draw_inset<D>(target: &mut D, at: Point, dash: &Dashboard<'_>) -> Result<(), D::Error>
where
    D: DrawTarget<Color = Rgb565>,
{
    let (fw, fh) = (PANEL.width as i32, PANEL.height as i32);
    let (iw, ih) = (INSET.width as i32, INSET.height as i32);
    let Some(cue) = dash.regions.first() else {
        return Ok(());
    };
    // Centre the window on the cue, inside the frame.
    let cx = (i32::from(cue.x_min) + i32::from(cue.x_max)) / 2;
    let cy = (i32::from(cue.y_min) + i32::from(cue.y_max)) / 2;
    let x0 = (cx - iw / 2).clamp(0, (fw - iw).max(0));
    let y0 = (cy - ih / 2).clamp(0, (fh - ih).max(0));
    let area = Rectangle::new(at, INSET * ZOOM);
    let z = ZOOM as i32;
    let colors = (0..ih * z).flat_map(|oy| {
        (0..iw * z).map(move |ox| {
            let (x, y) = (x0 + ox / z, y0 + oy / z);
            let i = (y * fw + x) as usize;
            color(dash.frame.get(i).copied().unwrap_or(0))
        })
    });
    target.fill_contiguous(&area, colors)?;
    // The cue's box, scaled, clipped to the inset.
    let mut inset = target.cropped(&area);
    let corner = Point::new(
        (i32::from(cue.x_min) - x0) * z - 1,
        (i32::from(cue.y_min) - y0) * z - 1,
    );
    let size = Size::new(
        u32::from(cue.width()) * ZOOM + 2,
        u32::from(cue.height()) * ZOOM + 2,
    );
    Rectangle::new(corner, size)
        .into_styled(PrimitiveStyle::with_stroke(CUE_COLORS[0], 1))
        .draw(&mut inset)
}
