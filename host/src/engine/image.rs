//! What the engine gives for a pair besides the bytes: the fields, and the
//! image of the variant (the representation rearranged, or the colour
//! wheel of the fields).

use crate::FlowPlanes;
use crate::engine::viz;
use crate::settings::Variant;

/// One result: the fields of a frame pair and its representation.
#[derive(Clone, Debug, PartialEq)]
pub struct PairFields {
    /// `v_c` and `v_d`.
    pub planes: FlowPlanes,
    /// The representation `[|v_d|, |v_c|, fⁿ]`, RGB8.
    pub rep: Vec<u8>,
}

/// The image a pair is shown as: a variant of the representation, or the
/// colour wheel of its fields.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Image {
    /// Which image.
    pub variant: Variant,
    /// Colour-wheel radius in pixels; `None`: each frame's longest vector.
    pub hsv_max: Option<f64>,
}

impl Image {
    /// Whether the image is made from the fields (the colour wheel) rather
    /// than from the representation's bytes alone.
    pub fn needs_fields(&self) -> bool {
        self.variant == Variant::Hsv
    }

    /// The RGB8 image of `fields`.
    pub fn of(&self, fields: &PairFields) -> Vec<u8> {
        if self.needs_fields() {
            let v_r = fields.planes.v_r();
            return viz::flow_to_rgb(&v_r.u, &v_r.v, self.hsv_max);
        }
        let mut rgb = fields.rep.clone();
        self.arrange(&mut rgb);
        rgb
    }

    /// Turn the representation `[|v_d|, |v_c|, f]` into the variant's
    /// image in place; a no-op for the colour wheel, which is made from
    /// the fields instead ([`Self::needs_fields`]).
    pub fn arrange(&self, rgb: &mut [u8]) {
        match self.variant {
            Variant::Dc | Variant::Hsv => {}
            Variant::Dc0 => rgb.chunks_exact_mut(3).for_each(|p| p[1] = 0),
            Variant::Cd => rgb.chunks_exact_mut(3).for_each(|p| p.swap(0, 1)),
        }
    }
}
