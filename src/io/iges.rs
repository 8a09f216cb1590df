//! IGES 5.3 writer: each skinned surface as one entity 128 (rational B-spline surface, here
//! polynomial: all weights 1, PROP3 = 1), units mm.
//!
//! In: surfaces in region order and a [`CadMeta`]. Out: a fixed-format ASCII file of 80-column
//! records in five sections: Start (S: the description), Global (G: delimiters `,` `;`, unit
//! flag 2 = "MM", version flag 11 = 5.3, fixed dates), Directory Entry (D: two records per
//! entity), Parameter Data (P: columns 1–64 data, 66–72 the entity's D sequence number) and
//! Terminate (T: record counts). Columns 73–80 hold the section letter and a 7-digit sequence
//! number restarting at 1 in each section. Tokens are never split across records.
//!
//! Periodic u is unwrapped as in [`super::cad`]: K1 + 1 = n+4 control points in u on the n+8
//! extended knots, PROP1 = 1 (closed in u), PROP4 = 1 (periodic in u), parameter range
//! U(0), U(1) = ξ_0, ξ_{n+1}: bskin's own parameters. v: clamped, PROP2 = PROP5 = 0.
//! Control points and weights run with the u index fastest, as the standard requires.
//!
//! Invariant: deterministic bytes (no clock time: the dates come from `meta.timestamp`).

use std::io::{self, Write};

use super::cad::{real, CadMeta, Unwrapped};
use crate::bspline::SkinnedSurface;

/// Columns of data in a Global record.
const G_WIDTH: usize = 72;
/// Columns of data in a Parameter record.
const P_WIDTH: usize = 64;

/// Writes `surfaces` as an IGES 5.3 file; see the module doc.
pub fn write_iges<W: Write>(
    out: W,
    surfaces: &[&SkinnedSurface],
    meta: &CadMeta,
) -> io::Result<()> {
    let unwrapped: Vec<Unwrapped> = surfaces.iter().map(|s| Unwrapped::of(s)).collect();
    let max_coord = unwrapped
        .iter()
        .map(Unwrapped::max_abs_coordinate)
        .fold(0.0, f64::max);

    let start = wrap_text(
        &format!(
            "{}; {} bicubic B-spline surface(s), patient {} mm",
            meta.description,
            surfaces.len(),
            meta.coordinates
        ),
        G_WIDTH,
    );
    let date = iges_date(&meta.timestamp);
    let global_tokens = vec![
        hollerith(","),
        hollerith(";"),
        hollerith(&meta.description),
        hollerith(&meta.file_name),
        hollerith(&meta.system),
        hollerith(&meta.system),
        "32".into(),
        "38".into(),
        "6".into(),
        "308".into(),
        "15".into(),
        hollerith(&meta.description),
        real(1.0),
        "2".into(),
        hollerith("MM"),
        "1".into(),
        real(1.0),
        hollerith(&date),
        real(1e-7),
        real(max_coord),
        hollerith(""),
        hollerith(""),
        "11".into(),
        "0".into(),
        hollerith(&date),
    ];
    let global = pack(&global_tokens, G_WIDTH);

    // Parameter data of each entity, then the directory entries pointing at it.
    let mut params: Vec<Vec<String>> = Vec::with_capacity(unwrapped.len());
    for un in &unwrapped {
        params.push(pack(&entity_128(un), P_WIDTH));
    }

    let mut o = io::BufWriter::new(out);
    for (i, l) in start.iter().enumerate() {
        record(&mut o, l, 'S', i + 1)?;
    }
    for (i, l) in global.iter().enumerate() {
        record(&mut o, l, 'G', i + 1)?;
    }
    let mut p_start = 1;
    for (k, lines) in params.iter().enumerate() {
        let de = 2 * k + 1;
        let l1 = format!(
            "{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
            128, p_start, 0, 0, 0, 0, 0, 0, "00000000"
        );
        let l2 = format!(
            "{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
            128,
            0,
            0,
            lines.len(),
            0,
            "",
            "",
            "BSKIN",
            k
        );
        record(&mut o, &l1, 'D', de)?;
        record(&mut o, &l2, 'D', de + 1)?;
        p_start += lines.len();
    }
    let mut seq = 1;
    for (k, lines) in params.iter().enumerate() {
        let de = 2 * k + 1;
        for l in lines {
            record(&mut o, &format!("{l:<64} {de:>7}"), 'P', seq)?;
            seq += 1;
        }
    }
    let t = format!(
        "S{:>7}G{:>7}D{:>7}P{:>7}",
        start.len(),
        global.len(),
        2 * params.len(),
        seq - 1
    );
    record(&mut o, &t, 'T', 1)?;
    o.flush()
}

/// Entity 128's parameters, the type number first.
fn entity_128(un: &Unwrapped) -> Vec<String> {
    let nu = un.rows.len();
    let nv = un.rows.first().map_or(0, |r| r.len());
    let mut t: Vec<String> =
        Vec::with_capacity(16 + un.u_knots.len() + un.v_knots.len() + 4 * nu * nv);
    for v in [128, nu - 1, nv - 1, 3, 3, 1, 0, 1, 1, 0] {
        t.push(v.to_string());
    }
    t.extend(un.u_knots.iter().map(|x| real(*x)));
    t.extend(un.v_knots.iter().map(|x| real(*x)));
    t.extend(std::iter::repeat_n(real(1.0), nu * nv));
    for j in 0..nv {
        for row in &un.rows {
            t.extend(row[j].iter().map(|x| real(*x)));
        }
    }
    t.push(real(un.u_domain.0));
    t.push(real(un.u_domain.1));
    t.push(real(un.v_domain.0));
    t.push(real(un.v_domain.1));
    t
}

/// Writes one 80-column record: `data` (at most 72 columns), the section letter, the sequence.
fn record<W: Write>(o: &mut W, data: &str, section: char, seq: usize) -> io::Result<()> {
    writeln!(o, "{data:<72}{section}{seq:>7}")
}

/// Tokens joined by `,` and ended by `;`, packed into records of at most `width` columns
/// without splitting a token (tokens are shorter than a record: numbers are ≤ 24 characters,
/// Hollerith strings are cut by [`hollerith`]).
fn pack(tokens: &[String], width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for (i, tok) in tokens.iter().enumerate() {
        let delim = if i + 1 == tokens.len() { ';' } else { ',' };
        let piece = format!("{tok}{delim}");
        if !cur.is_empty() && cur.len() + piece.len() > width {
            lines.push(std::mem::take(&mut cur));
        }
        cur.push_str(&piece);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// `nHtext`, printable ASCII only, cut so the token fits one Global record.
fn hollerith(s: &str) -> String {
    let clean: String = s
        .chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '?' })
        .take(G_WIDTH - 4)
        .collect();
    format!("{}H{}", clean.len(), clean)
}

/// Free text cut into records of `width` columns (the Start section).
fn wrap_text(s: &str, width: usize) -> Vec<String> {
    let clean: Vec<char> = s
        .chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '?' })
        .collect();
    if clean.is_empty() {
        return vec![String::new()];
    }
    clean
        .chunks(width)
        .map(|c| c.iter().collect::<String>())
        .collect()
}

/// "YYYY-MM-DDTHH:MM:SS" → IGES "YYYYMMDD.HHNNSS"; anything else → the fixed 2000-01-01.
fn iges_date(ts: &str) -> String {
    let digits: String = ts.chars().filter(|c| c.is_ascii_digit()).collect();
    if digits.len() >= 14 {
        format!("{}.{}", &digits[..8], &digits[8..14])
    } else {
        "20000101.000000".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_keeps_tokens_whole() {
        let toks: Vec<String> = (0..40).map(|i| format!("{}", 1000 * i)).collect();
        let lines = pack(&toks, 20);
        assert!(lines.iter().all(|l| l.len() <= 20));
        assert_eq!(lines.concat().trim_end_matches(';').split(',').count(), 40);
        assert!(lines.last().unwrap().ends_with(';'));
    }

    #[test]
    fn dates_and_strings() {
        assert_eq!(iges_date("2000-01-01T00:00:00"), "20000101.000000");
        assert_eq!(iges_date("garbage"), "20000101.000000");
        assert_eq!(hollerith("MM"), "2HMM");
        assert_eq!(hollerith("é"), "1H?");
    }
}
