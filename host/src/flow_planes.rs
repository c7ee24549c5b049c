//! The two fields of a frame pair as whole-frame `f64` planes: what both
//! engines compute, whatever else each adds (the fixed engine its exact
//! magnitudes, the command line the representation).

/// The curl-free field `v_c` and the divergence-free field `v_d` of a frame
/// pair, row-major planes of `width · height`, in pixels (x to the right,
/// y downward).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowPlanes {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Curl-free field `v_c`, x component.
    pub vcx: Vec<f64>,
    /// `v_c`, y component.
    pub vcy: Vec<f64>,
    /// Divergence-free field `v_d`, x component.
    pub vdx: Vec<f64>,
    /// `v_d`, y component.
    pub vdy: Vec<f64>,
}

impl FlowPlanes {
    /// ReynoldsFlow `v_R = v_c + v_d` (SPEC §3 step 10), as `(x, y)` planes.
    pub fn v_r(&self) -> (Vec<f64>, Vec<f64>) {
        let add = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a + b).collect();
        (add(&self.vcx, &self.vdx), add(&self.vcy, &self.vdy))
    }

    /// The motion score of the pair: the mean of `|v_R| = |v_c + v_d|` over
    /// the frame, in pixels per frame (0 for identical frames). What the
    /// Python `motion_score` returns and WebDataset samples record.
    pub fn mean_speed(&self) -> f64 {
        let sum: f64 = (0..self.vcx.len())
            .map(|i| (self.vcx[i] + self.vdx[i]).hypot(self.vcy[i] + self.vdy[i]))
            .sum();
        sum / self.vcx.len().max(1) as f64
    }

    /// The magnitudes `(m_d, m_c) = (|v_d|, |v_c|)` (SPEC §3 step 11), in the
    /// order of the representation's R and G channels.
    pub fn magnitudes(&self) -> (Vec<f64>, Vec<f64>) {
        let norm = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .map(|(x, y)| (x * x + y * y).sqrt())
                .collect()
        };
        (norm(&self.vdx, &self.vdy), norm(&self.vcx, &self.vcy))
    }
}
