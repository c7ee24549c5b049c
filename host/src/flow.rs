//! Flow fields: one dense vector field ([`Flow`]), which `.flo` files hold
//! and the evaluation measures, and the two fields of a frame pair
//! ([`FlowPlanes`]), which both engines compute.

/// A dense vector field: pixel `(x, y)` carries `(u, v)`, x to the right,
/// y downward, in pixels (a displacement from frame n to frame n + 1, or
/// one of ReynoldsFlow's fields), row-major planes of `width · height`.
#[derive(Clone, Debug, PartialEq)]
pub struct Flow {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// x components, row-major.
    pub u: Vec<f64>,
    /// y components, row-major.
    pub v: Vec<f64>,
}

impl Flow {
    /// The zero field.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            u: vec![0.0; width * height],
            v: vec![0.0; width * height],
        }
    }

    /// A field from its two component planes.
    ///
    /// # Panics
    /// If a plane does not hold `width · height` values.
    pub fn from_parts(width: usize, height: usize, u: Vec<f64>, v: Vec<f64>) -> Self {
        assert!(
            u.len() == width * height && v.len() == width * height,
            "plane size"
        );
        Self {
            width,
            height,
            u,
            v,
        }
    }

    /// The vector at row-major index `i`.
    pub fn at(&self, i: usize) -> [f64; 2] {
        [self.u[i], self.v[i]]
    }

    /// Each vector's Euclidean length.
    pub fn lengths(&self) -> Vec<f64> {
        self.u
            .iter()
            .zip(&self.v)
            .map(|(x, y)| (x * x + y * y).sqrt())
            .collect()
    }

    /// The sum of two fields of one size, vector by vector.
    fn plus(&self, other: &Flow) -> Flow {
        let add = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a + b).collect();
        Flow::from_parts(
            self.width,
            self.height,
            add(&self.u, &other.u),
            add(&self.v, &other.v),
        )
    }
}

/// The curl-free field `v_c` and the divergence-free field `v_d` of a frame
/// pair, of one size.
#[derive(Clone, Debug, PartialEq)]
pub struct FlowPlanes {
    /// Curl-free field `v_c`.
    pub v_c: Flow,
    /// Divergence-free field `v_d`.
    pub v_d: Flow,
}

impl FlowPlanes {
    /// Columns.
    pub fn width(&self) -> usize {
        self.v_c.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.v_c.height
    }

    /// ReynoldsFlow `v_R = v_c + v_d` (SPEC §3 step 10).
    pub fn v_r(&self) -> Flow {
        self.v_c.plus(&self.v_d)
    }

    /// The motion score of the pair: the mean of `|v_R| = |v_c + v_d|` over
    /// the frame, in pixels per frame (0 for identical frames). What the
    /// Python `motion_score` returns and WebDataset samples record.
    pub fn mean_speed(&self) -> f64 {
        let (c, d) = (&self.v_c, &self.v_d);
        let sum: f64 = (0..c.u.len())
            .map(|i| (c.u[i] + d.u[i]).hypot(c.v[i] + d.v[i]))
            .sum();
        sum / c.u.len().max(1) as f64
    }

    /// The magnitudes `(m_d, m_c) = (|v_d|, |v_c|)` (SPEC §3 step 11), in the
    /// order of the representation's R and G channels.
    pub fn magnitudes(&self) -> (Vec<f64>, Vec<f64>) {
        (self.v_d.lengths(), self.v_c.lengths())
    }
}
