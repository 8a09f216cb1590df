//! Contour NDJSON, version 1: the compiled contours of a series, one JSON record a line.
//!
//! ```text
//! {"type":"series","format":"bskin-contours","version":1,"series":{..},"slices":N,
//!  "threshold":{"above":300} | {"range":[lo,hi]},"min_area_mm2":..,"fill_holes":..,
//!  "compress_tol_mm":..,"units":"mm","coordinates":"LPS"}
//! {"type":"slice","index":0,"origin":[x,y,z],"row":[..],"col":[..],"height":h,
//!  "file":"..","contours":[{"points":[[x,y],..],"hole":false},..]}
//! ... one slice record per slice, in ascending height, empty or not ...
//! {"type":"end","slices":N,"contours":C,"points":P}
//! ```
//! A 3-D point is `origin + x·row + y·col` in patient mm (LPS). Coordinates are rounded to
//! 0.1 µm. The `end` record lets a reader tell a complete stream from a truncated one. The
//! reader accepts streams written by other tools: only `type`, `index`, `origin`, `row`,
//! `col` and `contours` are required; `hole` defaults to the sign of the polygon's area.

use std::io::{BufRead, Write};

use serde::{Deserialize, Serialize};

use crate::geometry::contours::{ContourOptions, Threshold};
use crate::geometry::polygon::signed_area;
use crate::section::{Contour, Section, SeriesSummary, SliceFrame, SliceSource};
use crate::{Error, Result};

pub const FORMAT: &str = "bskin-contours";
pub const VERSION: u32 = 1;

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdRecord {
    Above(f64),
    Range([f64; 2]),
}

impl From<Threshold> for ThresholdRecord {
    fn from(t: Threshold) -> Self {
        match t {
            Threshold::Above(t) => ThresholdRecord::Above(t),
            Threshold::Range(lo, hi) => ThresholdRecord::Range([lo, hi]),
        }
    }
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct SeriesRecord {
    pub format: String,
    pub version: u32,
    pub series: SeriesSummary,
    pub slices: usize,
    pub threshold: Option<ThresholdRecord>,
    pub min_area_mm2: Option<f64>,
    pub fill_holes: Option<bool>,
    pub compress_tol_mm: Option<f64>,
    pub units: String,
    pub coordinates: String,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct ContourRecord {
    pub points: Vec<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hole: Option<bool>,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct SliceRecord {
    pub index: usize,
    pub origin: [f64; 3],
    pub row: [f64; 3],
    pub col: [f64; 3],
    #[serde(default)]
    pub height: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    pub contours: Vec<ContourRecord>,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct EndRecord {
    pub slices: usize,
    pub contours: usize,
    pub points: usize,
}

/// The largest coordinate a stream may give, in mm: a kilometre, far beyond any scanner's
/// field, and far enough inside f64's range that the grids and distances built on the
/// points stay finite (a point at 1e308 mm made stage 4's raster cell infinite).
pub const MAX_COORDINATE_MM: f64 = 1e6;

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Record {
    Series(SeriesRecord),
    Slice(SliceRecord),
    End(EndRecord),
}

impl SeriesRecord {
    pub fn new(series: &SeriesSummary, opts: &ContourOptions) -> Self {
        SeriesRecord {
            format: FORMAT.into(),
            version: VERSION,
            series: series.clone(),
            slices: series.slices,
            threshold: Some(opts.threshold.into()),
            min_area_mm2: Some(opts.min_area_mm2),
            fill_holes: Some(opts.fill_holes),
            compress_tol_mm: Some(opts.compress_tol_mm),
            units: "mm".into(),
            coordinates: "LPS".into(),
        }
    }
}

impl SliceRecord {
    pub fn new(section: &Section) -> Self {
        let f = &section.frame;
        SliceRecord {
            index: section.index,
            origin: f.origin,
            row: f.row,
            col: f.col,
            height: Some(f.height()),
            file: Some(section.source.to_string()),
            contours: section
                .contours
                .iter()
                .map(|c| ContourRecord {
                    points: c.points.clone(),
                    hole: Some(c.hole),
                })
                .collect(),
        }
    }

    /// The section this record describes; `line` is for error messages.
    pub fn into_section(self, line: usize) -> Result<Section> {
        let bad = |msg: String| Error::bad_input(format!("NDJSON line {line}"), msg);
        let all = self.origin.iter().chain(&self.row).chain(&self.col);
        if all.clone().any(|v| !v.is_finite()) {
            return Err(bad(format!(
                "slice {}: non-finite origin/row/col",
                self.index
            )));
        }
        if let Some(v) = self.origin.iter().find(|v| v.abs() > MAX_COORDINATE_MM) {
            return Err(bad(format!(
                "slice {}: origin coordinate {v:e} mm is beyond {MAX_COORDINATE_MM:e} mm",
                self.index
            )));
        }
        let frame = SliceFrame {
            origin: self.origin,
            row: self.row,
            col: self.col,
        };
        let n = frame.normal();
        if n.iter().any(|v| !v.is_finite()) {
            return Err(bad(format!(
                "slice {}: row and col are parallel or zero",
                self.index
            )));
        }
        let mut contours = Vec::with_capacity(self.contours.len());
        for (k, c) in self.contours.into_iter().enumerate() {
            // One pass over the points for both checks.
            let bad_at = c.points.iter().enumerate().find_map(|(i, p)| {
                let v = p
                    .iter()
                    .copied()
                    .find(|v| !v.is_finite() || v.abs() > MAX_COORDINATE_MM)?;
                Some((i, v))
            });
            if let Some((i, v)) = bad_at {
                return Err(bad(if v.is_finite() {
                    format!(
                        "slice {}, contour {k}: point {i} has a coordinate of {v:e} mm, beyond {MAX_COORDINATE_MM:e} mm",
                        self.index
                    )
                } else {
                    format!("slice {}, contour {k}: non-finite point", self.index)
                }));
            }
            if c.points.len() < 3 {
                return Err(bad(format!(
                    "slice {}, contour {k}: {} points, a contour needs at least 3",
                    self.index,
                    c.points.len()
                )));
            }
            let area = signed_area(&c.points);
            let hole = c.hole.unwrap_or(area < 0.0);
            let mut points = c.points;
            // Normalise orientation: outer CCW, holes CW.
            if (area < 0.0) != hole {
                points.reverse();
            }
            contours.push(Contour { points, hole });
        }
        Ok(Section {
            index: self.index,
            frame,
            source: SliceSource {
                path: self.file.unwrap_or_default().into(),
                frame: None,
            },
            contours,
        })
    }
}

/// Writes the records of one series as they come.
pub struct NdjsonWriter<W: Write> {
    out: W,
    end: EndRecord,
}

impl<W: Write> NdjsonWriter<W> {
    pub fn new(mut out: W, header: &SeriesRecord) -> std::io::Result<Self> {
        write_record(&mut out, &Record::Series(header.clone()))?;
        Ok(NdjsonWriter {
            out,
            end: EndRecord {
                slices: 0,
                contours: 0,
                points: 0,
            },
        })
    }

    pub fn write_section(&mut self, section: &Section) -> std::io::Result<()> {
        self.end.slices += 1;
        self.end.contours += section.contours.len();
        self.end.points += section
            .contours
            .iter()
            .map(|c| c.points.len())
            .sum::<usize>();
        write_record(&mut self.out, &Record::Slice(SliceRecord::new(section)))
    }

    /// Write the `end` record and hand back the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        write_record(&mut self.out, &Record::End(self.end.clone()))?;
        self.out.flush()?;
        Ok(self.out)
    }
}

fn write_record<W: Write>(out: &mut W, r: &Record) -> std::io::Result<()> {
    serde_json::to_writer(&mut *out, r)?;
    out.write_all(b"\n")
}

/// Reads a contour NDJSON stream: its header (if any), then sections in order.
pub struct NdjsonReader<R: BufRead> {
    input: R,
    line: usize,
    pub header: Option<SeriesRecord>,
    pub ended: bool,
    peeked: Option<SliceRecord>,
    reported_truncation: bool,
}

impl<R: BufRead> NdjsonReader<R> {
    /// Reads up to the first slice record, so the header is known.
    pub fn new(input: R) -> Result<Self> {
        let mut r = NdjsonReader {
            input,
            line: 0,
            header: None,
            ended: false,
            peeked: None,
            reported_truncation: false,
        };
        r.peeked = r.next_slice()?;
        Ok(r)
    }

    fn next_slice(&mut self) -> Result<Option<SliceRecord>> {
        let mut buf = String::new();
        loop {
            buf.clear();
            let n = self
                .input
                .read_line(&mut buf)
                .map_err(|e| Error::io(format!("NDJSON line {}", self.line + 1), e))?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            if buf.trim().is_empty() {
                continue;
            }
            let rec: Record = serde_json::from_str(&buf).map_err(|e| {
                Error::bad_input(format!("NDJSON line {}", self.line), e.to_string())
            })?;
            match rec {
                Record::Series(h) => self.header = Some(h),
                Record::Slice(s) => return Ok(Some(s)),
                Record::End(_) => self.ended = true,
            }
        }
    }
}

impl<R: BufRead> Iterator for NdjsonReader<R> {
    type Item = Result<Section>;
    fn next(&mut self) -> Option<Result<Section>> {
        let rec = match self.peeked.take() {
            Some(r) => r,
            None => match self.next_slice() {
                Ok(Some(r)) => r,
                Ok(None) if self.header.is_some() && !self.ended && !self.reported_truncation => {
                    // A stream that announced itself must end with its end record.
                    self.reported_truncation = true;
                    return Some(Err(Error::bad_input(
                        format!("NDJSON line {}", self.line),
                        "the stream ends without its \"end\" record: truncated",
                    )));
                }
                Ok(None) => return None,
                Err(e) => return Some(Err(e)),
            },
        };
        let line = self.line;
        Some(rec.into_section(line))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(index: usize) -> Section {
        Section {
            index,
            frame: SliceFrame {
                origin: [-10.0, 5.0, index as f64 * 1.5],
                row: [1.0, 0.0, 0.0],
                col: [0.0, 1.0, 0.0],
            },
            source: SliceSource {
                path: format!("slice{index}.dcm").into(),
                frame: None,
            },
            contours: vec![
                Contour {
                    points: vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]],
                    hole: false,
                },
                Contour {
                    points: vec![[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]],
                    hole: true,
                },
            ],
        }
    }

    #[test]
    fn round_trip_keeps_sections_and_header() {
        let header = SeriesRecord::new(&SeriesSummary::default(), &ContourOptions::default());
        let mut w = NdjsonWriter::new(Vec::new(), &header).unwrap();
        for k in 0..3 {
            w.write_section(&section(k)).unwrap();
        }
        let bytes = w.finish().unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert_eq!(text.lines().count(), 5);
        assert!(text.starts_with("{\"type\":\"series\""));
        let mut r = NdjsonReader::new(&bytes[..]).unwrap();
        let got: Vec<Section> = r.by_ref().map(|s| s.unwrap()).collect();
        assert_eq!(got, (0..3).map(section).collect::<Vec<_>>());
        assert!(r.ended);
        assert_eq!(r.header.unwrap(), header);
    }

    #[test]
    fn points_and_frames_survive_to_the_last_bit() {
        // `contours | run -` must give the bytes `run DIR` gives; one ulp off changes
        // discrete choices downstream (the GE head: 292 surfaces direct, 286 piped).
        let mut s = section(1);
        let awkward = |k: usize| (k as f64 + 1.0).sqrt() * 37.123456789 - 0.1;
        s.frame.origin = [awkward(1), -awkward(2), awkward(3) * 1e-3];
        s.frame.col = [
            0.0,
            awkward(4) / awkward(4).hypot(0.3),
            0.3 / awkward(4).hypot(0.3),
        ];
        for (k, p) in s.contours[0].points.iter_mut().enumerate() {
            *p = [p[0] + awkward(k) * 1e-7, p[1] + awkward(k + 9)];
        }
        let header = SeriesRecord::new(&SeriesSummary::default(), &ContourOptions::default());
        let mut w = NdjsonWriter::new(Vec::new(), &header).unwrap();
        w.write_section(&s).unwrap();
        let bytes = w.finish().unwrap();
        let got: Vec<Section> = NdjsonReader::new(&bytes[..])
            .unwrap()
            .map(|s| s.unwrap())
            .collect();
        assert_eq!(got, vec![s]);
    }

    #[test]
    fn foreign_streams_get_orientation_from_area_and_clear_errors() {
        let line = r#"{"type":"slice","index":0,"origin":[0,0,0],"row":[1,0,0],"col":[0,1,0],"contours":[{"points":[[0,0],[0,1],[1,1],[1,0]]}]}"#;
        let s: Vec<_> = NdjsonReader::new(line.as_bytes()).unwrap().collect();
        let s = s[0].as_ref().unwrap();
        assert!(
            s.contours[0].hole,
            "a clockwise contour without a flag is a hole"
        );

        let far = r#"{"type":"slice","index":2,"origin":[0,0,0],"row":[1,0,0],"col":[0,1,0],"contours":[{"points":[[0,0],[1e308,0],[1,1]]}]}"#;
        let s: Vec<_> = NdjsonReader::new(far.as_bytes()).unwrap().collect();
        let msg = s[0].as_ref().unwrap_err().to_string();
        assert!(msg.contains("line 1") && msg.contains("point 1"), "{msg}");
        let far = r#"{"type":"slice","index":2,"origin":[0,-2e6,0],"row":[1,0,0],"col":[0,1,0],"contours":[]}"#;
        let s: Vec<_> = NdjsonReader::new(far.as_bytes()).unwrap().collect();
        let msg = s[0].as_ref().unwrap_err().to_string();
        assert!(msg.contains("origin coordinate -2e6 mm"), "{msg}");

        let nan = r#"{"type":"slice","index":3,"origin":[0,0,0],"row":[1,0,0],"col":[0,1,0],"contours":[{"points":[[0,0],[1,0]]}]}"#;
        let s: Vec<_> = NdjsonReader::new(nan.as_bytes()).unwrap().collect();
        let msg = s[0].as_ref().unwrap_err().to_string();
        assert!(msg.contains("line 1") && msg.contains("2 points"), "{msg}");
    }

    #[test]
    fn a_stream_cut_at_a_line_boundary_is_truncated() {
        let header = SeriesRecord::new(&SeriesSummary::default(), &ContourOptions::default());
        let mut w = NdjsonWriter::new(Vec::new(), &header).unwrap();
        w.write_section(&section(0)).unwrap();
        let bytes = w.finish().unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let without_end: String = text.lines().take(2).map(|l| format!("{l}\n")).collect();
        let got: Vec<_> = NdjsonReader::new(without_end.as_bytes()).unwrap().collect();
        assert_eq!(got.len(), 2);
        assert!(got[0].is_ok());
        assert!(got[1]
            .as_ref()
            .unwrap_err()
            .to_string()
            .contains("truncated"));
    }
}
