//! Tests' rows: whole pixels laid out as the engine hands them to a sink.

use std::vec::Vec;

use reynoldsflow_core::{Fields, FlowPixel, Pixels};

/// Each quantity of some pixels as a row.
pub struct Rows {
    m_d: Vec<f32>,
    m_c: Vec<f32>,
    luma: Vec<u8>,
    fields: [Vec<f32>; 4],
}

impl Rows {
    pub fn of(pixels: &[FlowPixel]) -> Self {
        let row = |f: fn(&FlowPixel) -> f32| pixels.iter().map(f).collect();
        Self {
            m_d: pixels.iter().map(|p| p.m_d).collect(),
            m_c: pixels.iter().map(|p| p.m_c).collect(),
            luma: pixels.iter().map(|p| p.luma).collect(),
            fields: [
                row(|p| p.v_c[0]),
                row(|p| p.v_c[1]),
                row(|p| p.v_d[0]),
                row(|p| p.v_d[1]),
            ],
        }
    }

    /// The rows, fields included.
    pub fn pixels(&self) -> Pixels<'_> {
        let [a, b, c, d] = self.fields.each_ref().map(|row| &row[..]);
        Pixels {
            m_d: &self.m_d,
            m_c: &self.m_c,
            luma: &self.luma,
            fields: Some(Fields {
                v_c: [a, b],
                v_d: [c, d],
            }),
        }
    }
}
