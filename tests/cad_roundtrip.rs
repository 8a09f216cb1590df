//! CAD writers, round trip without a CAD kernel: write STEP and IGES for small skinned
//! surfaces (ellipses fitted on one knot vector, one with a cap), read them back with the
//! small test-only parsers below, evaluate the parsed B-splines with the ordinary
//! (non-periodic) Cox–de Boor recursion and compare with `SkinnedSurface::eval`. Also: the
//! STEP topology (one face per surface, its edges' curves run between its vertices, the seam
//! is S(0, ·)), the IGES record structure (80 columns, section letters, sequence numbers,
//! directory/parameter pointers, the Terminate counts), mm units, and identical bytes from
//! identical input. OpenCASCADE itself is exercised by scripts/check_cad.py in CI.

use std::collections::BTreeMap;

use bskin::bspline::{fit_common, skin, FitOptions, SkinnedSurface};
use bskin::io::cad::CadMeta;
use bskin::io::iges::write_iges;
use bskin::io::step::write_step;

type P3 = [f64; 3];

// ---------------------------------------------------------------------------------------------
// Surfaces under test.

fn ellipse(m: usize, a: f64, b: f64, phase: f64, z: f64) -> Vec<P3> {
    (0..m)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / m as f64 + phase;
            [a * t.cos() + 0.3 * z.sin(), b * t.sin(), z]
        })
        .collect()
}

fn surface(cap: bool) -> SkinnedSurface {
    let mut contours: Vec<Vec<P3>> = (0..5)
        .map(|k| {
            let z = 2.5 * k as f64;
            ellipse(
                40 + 3 * k,
                10.0 + k as f64,
                6.0 - 0.4 * k as f64,
                0.1 * k as f64,
                z,
            )
        })
        .collect();
    if cap {
        contours.push(vec![[0.5, 0.2, 13.0]]);
    }
    let f = fit_common(&contours, &FitOptions::new(0.05)).unwrap();
    skin(&f.curves).unwrap()
}

fn surfaces() -> Vec<SkinnedSurface> {
    vec![surface(false), surface(true)]
}

fn meta(name: &str) -> CadMeta {
    CadMeta {
        file_name: name.into(),
        ..Default::default()
    }
}

fn sample_params(s: &SkinnedSurface) -> Vec<(f64, f64)> {
    let d = s.u_knots().domain();
    let (ua, ub) = (d[0], d[d.len() - 1]);
    let (va, vb) = s.v_knots().domain();
    let mut out = Vec::new();
    for fu in [0.0, 0.01, 0.2, 0.333, 0.5, 0.77, 0.999] {
        for fv in [0.0, 0.1, 0.45, 0.9, 1.0] {
            out.push((ua + fu * (ub - ua), va + fv * (vb - va)));
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Independent evaluation: the textbook non-periodic B-spline.

/// Basis functions N_{i,p}(t), i = 0..n, by the Cox–de Boor recursion; at the right end of
/// the domain the last non-empty span is used.
fn cox_de_boor(knots: &[f64], p: usize, t: f64) -> Vec<f64> {
    let n = knots.len() - p - 1;
    let end = knots[n];
    let in_span = |i: usize| -> bool {
        if t == end {
            knots[i] < knots[i + 1] && knots[i + 1] == end
        } else {
            knots[i] <= t && t < knots[i + 1]
        }
    };
    let mut nb: Vec<f64> = (0..knots.len() - 1)
        .map(|i| if in_span(i) { 1.0 } else { 0.0 })
        .collect();
    for d in 1..=p {
        let next: Vec<f64> = (0..knots.len() - 1 - d)
            .map(|i| {
                let mut v = 0.0;
                let l = knots[i + d] - knots[i];
                if l > 0.0 {
                    v += (t - knots[i]) / l * nb[i];
                }
                let r = knots[i + d + 1] - knots[i + 1];
                if r > 0.0 {
                    v += (knots[i + d + 1] - t) / r * nb[i + 1];
                }
                v
            })
            .collect();
        nb = next;
    }
    nb.truncate(n);
    nb
}

/// `ctrl[i][j]`, i along u.
fn eval_open(uk: &[f64], vk: &[f64], ctrl: &[Vec<P3>], u: f64, v: f64) -> P3 {
    let nu = cox_de_boor(uk, 3, u);
    let nv = cox_de_boor(vk, 3, v);
    assert_eq!(nu.len(), ctrl.len(), "u basis count vs control rows");
    let mut p = [0.0; 3];
    for (i, a) in nu.iter().enumerate() {
        assert_eq!(nv.len(), ctrl[i].len(), "v basis count vs control columns");
        for (j, b) in nv.iter().enumerate() {
            for x in 0..3 {
                p[x] += a * b * ctrl[i][j][x];
            }
        }
    }
    p
}

fn eval_curve(knots: &[f64], ctrl: &[P3], t: f64) -> P3 {
    let nb = cox_de_boor(knots, 3, t);
    assert_eq!(nb.len(), ctrl.len());
    let mut p = [0.0; 3];
    for (a, c) in nb.iter().zip(ctrl) {
        for x in 0..3 {
            p[x] += a * c[x];
        }
    }
    p
}

fn dist(a: &P3, b: &P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn expand(values: &[f64], mults: &[i64]) -> Vec<f64> {
    assert_eq!(values.len(), mults.len());
    values
        .iter()
        .zip(mults)
        .flat_map(|(v, m)| std::iter::repeat_n(*v, *m as usize))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// A minimal ISO 10303-21 reader: entity id → (type name, parameters).

#[derive(Debug, Clone, PartialEq)]
enum V {
    Ref(usize),
    Int(i64),
    Real(f64),
    Str(String),
    Enum(String),
    Unset,
    List(Vec<V>),
    Typed(String, Vec<V>),
}

impl V {
    fn list(&self) -> &[V] {
        match self {
            V::List(v) => v,
            other => panic!("expected a list, got {other:?}"),
        }
    }
    fn id(&self) -> usize {
        match self {
            V::Ref(i) => *i,
            other => panic!("expected a reference, got {other:?}"),
        }
    }
    fn num(&self) -> f64 {
        match self {
            V::Real(x) => *x,
            V::Int(i) => *i as f64,
            other => panic!("expected a number, got {other:?}"),
        }
    }
    fn int(&self) -> i64 {
        match self {
            V::Int(i) => *i,
            other => panic!("expected an integer, got {other:?}"),
        }
    }
    fn enm(&self) -> &str {
        match self {
            V::Enum(e) => e,
            other => panic!("expected an enumeration, got {other:?}"),
        }
    }
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn peek(&self) -> u8 {
        self.s[self.i]
    }
    fn eat(&mut self, c: u8) {
        assert_eq!(self.peek() as char, c as char, "at byte {}", self.i);
        self.i += 1;
    }
    fn word(&mut self) -> String {
        let st = self.i;
        while self.peek().is_ascii_alphanumeric() || self.peek() == b'_' {
            self.i += 1;
        }
        String::from_utf8(self.s[st..self.i].to_vec()).unwrap()
    }
    fn list(&mut self) -> Vec<V> {
        self.eat(b'(');
        let mut out = Vec::new();
        if self.peek() == b')' {
            self.i += 1;
            return out;
        }
        loop {
            out.push(self.value());
            match self.peek() {
                b',' => self.i += 1,
                b')' => {
                    self.i += 1;
                    return out;
                }
                c => panic!("unexpected {:?} at byte {}", c as char, self.i),
            }
        }
    }
    fn value(&mut self) -> V {
        match self.peek() {
            b'#' => {
                self.i += 1;
                V::Ref(self.word().parse().unwrap())
            }
            b'\'' => {
                self.i += 1;
                let mut s = String::new();
                loop {
                    let c = self.peek();
                    self.i += 1;
                    if c == b'\'' {
                        if self.peek() == b'\'' {
                            self.i += 1;
                            s.push('\'');
                        } else {
                            return V::Str(s);
                        }
                    } else {
                        s.push(c as char);
                    }
                }
            }
            b'.' => {
                self.i += 1;
                let w = self.word();
                self.eat(b'.');
                V::Enum(w)
            }
            b'$' | b'*' => {
                self.i += 1;
                V::Unset
            }
            b'(' => V::List(self.list()),
            c if c.is_ascii_digit() || c == b'-' || c == b'+' => {
                let st = self.i;
                while matches!(self.peek(), b'0'..=b'9' | b'.' | b'E' | b'e' | b'-' | b'+') {
                    self.i += 1;
                }
                let t = std::str::from_utf8(&self.s[st..self.i]).unwrap();
                if t.contains('.') {
                    V::Real(t.parse().unwrap_or_else(|_| panic!("bad real {t}")))
                } else {
                    V::Int(t.parse().unwrap())
                }
            }
            _ => {
                let name = self.word();
                V::Typed(name.clone(), self.list())
            }
        }
    }
}

struct Step {
    header: String,
    /// id → (type, parameters); complex instances get type "(complex)" and their parts.
    ents: BTreeMap<usize, (String, Vec<V>)>,
}

impl Step {
    fn parse(text: &str) -> Step {
        assert!(text.starts_with("ISO-10303-21;\nHEADER;\n"));
        assert!(text.ends_with("ENDSEC;\nEND-ISO-10303-21;\n"));
        let (header, data) = text.split_once("DATA;\n").unwrap();
        let data = data.strip_suffix("ENDSEC;\nEND-ISO-10303-21;\n").unwrap();
        let mut ents = BTreeMap::new();
        for (expected_id, line) in (1..).zip(data.lines()) {
            let body = line
                .strip_suffix(';')
                .expect("one entity per line, ';' at the end");
            let (id, rest) = body.split_once('=').unwrap();
            let id: usize = id.strip_prefix('#').unwrap().parse().unwrap();
            assert_eq!(id, expected_id, "ids are consecutive");
            let mut p = Parser {
                s: rest.as_bytes(),
                i: 0,
            };
            let e = if rest.starts_with('(') {
                // A complex instance: typed parts side by side, no separators.
                p.eat(b'(');
                let mut parts = Vec::new();
                while p.peek() != b')' {
                    parts.push(p.value());
                }
                p.eat(b')');
                ("(complex)".to_string(), parts)
            } else {
                match p.value() {
                    V::Typed(n, a) => (n, a),
                    other => panic!("#{id}: {other:?}"),
                }
            };
            assert_eq!(p.i, rest.len(), "#{id} fully parsed");
            assert!(ents.insert(id, e).is_none());
        }
        Step {
            header: header.to_string(),
            ents,
        }
    }
    fn get(&self, id: usize) -> &(String, Vec<V>) {
        &self.ents[&id]
    }
    fn of_type(&self, t: &str) -> Vec<usize> {
        self.ents
            .iter()
            .filter(|(_, (n, _))| n == t)
            .map(|(i, _)| *i)
            .collect()
    }
    fn point(&self, id: usize) -> P3 {
        let (t, a) = self.get(id);
        assert_eq!(t, "CARTESIAN_POINT");
        let c = a[1].list();
        assert_eq!(c.len(), 3);
        [c[0].num(), c[1].num(), c[2].num()]
    }
    fn vertex(&self, id: usize) -> P3 {
        let (t, a) = self.get(id);
        assert_eq!(t, "VERTEX_POINT");
        self.point(a[1].id())
    }
    /// B_SPLINE_CURVE_WITH_KNOTS → (knots, control points, closed).
    fn curve(&self, id: usize) -> (Vec<f64>, Vec<P3>, bool) {
        let (t, a) = self.get(id);
        assert_eq!(t, "B_SPLINE_CURVE_WITH_KNOTS");
        assert_eq!(a[1].int(), 3);
        let pts: Vec<P3> = a[2].list().iter().map(|r| self.point(r.id())).collect();
        let mults: Vec<i64> = a[6].list().iter().map(V::int).collect();
        let vals: Vec<f64> = a[7].list().iter().map(V::num).collect();
        (expand(&vals, &mults), pts, a[4].enm() == "T")
    }
}

// ---------------------------------------------------------------------------------------------

#[test]
fn step_reproduces_the_surfaces() {
    let surfs = surfaces();
    let refs: Vec<&SkinnedSurface> = surfs.iter().collect();
    let mut bytes = Vec::new();
    write_step(&mut bytes, &refs, &meta("t.step")).unwrap();
    let mut again = Vec::new();
    write_step(&mut again, &refs, &meta("t.step")).unwrap();
    assert_eq!(bytes, again, "deterministic bytes");
    let text = String::from_utf8(bytes).unwrap();
    assert!(text.is_ascii());
    let step = Step::parse(&text);
    assert!(step
        .header
        .contains("FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));"));
    assert!(step.header.contains("'2000-01-01T00:00:00'"), "fixed date");

    // Units: one complex instance with LENGTH_UNIT and SI_UNIT(.MILLI., .METRE.).
    let mm = step
        .of_type("(complex)")
        .into_iter()
        .filter(|&i| {
            let parts = &step.get(i).1;
            parts.contains(&V::Typed("LENGTH_UNIT".into(), vec![]))
                && parts.contains(&V::Typed(
                    "SI_UNIT".into(),
                    vec![V::Enum("MILLI".into()), V::Enum("METRE".into())],
                ))
        })
        .count();
    assert_eq!(mm, 1, "length unit mm");

    // One face, one shell per surface; one model in one representation tied to the product.
    let n = surfs.len();
    for (t, want) in [
        ("B_SPLINE_SURFACE_WITH_KNOTS", n),
        ("ADVANCED_FACE", n),
        ("OPEN_SHELL", n),
        ("SHELL_BASED_SURFACE_MODEL", 1),
        ("MANIFOLD_SURFACE_SHAPE_REPRESENTATION", 1),
        ("SHAPE_DEFINITION_REPRESENTATION", 1),
        ("PRODUCT", 1),
    ] {
        assert_eq!(step.of_type(t).len(), want, "{t}");
    }
    let model = &step.get(step.of_type("SHELL_BASED_SURFACE_MODEL")[0]).1;
    let shells: Vec<usize> = model[1].list().iter().map(V::id).collect();
    assert_eq!(shells, step.of_type("OPEN_SHELL"));

    for (k, (shell, s)) in shells.iter().zip(&surfs).enumerate() {
        let faces = step.get(*shell).1[1].list();
        assert_eq!(faces.len(), 1);
        let (ft, fa) = step.get(faces[0].id());
        assert_eq!(ft, "ADVANCED_FACE");
        let (st, sa) = step.get(fa[2].id());
        assert_eq!(st, "B_SPLINE_SURFACE_WITH_KNOTS");
        assert_eq!((sa[1].int(), sa[2].int()), (3, 3), "bicubic");
        assert_eq!(sa[4].enm(), "UNSPECIFIED");
        assert_eq!(sa[5].enm(), "T", "u_closed");
        assert_eq!(sa[6].enm(), "F", "v_closed");
        let ctrl: Vec<Vec<P3>> = sa[3]
            .list()
            .iter()
            .map(|row| row.list().iter().map(|p| step.point(p.id())).collect())
            .collect();
        assert_eq!(ctrl.len(), s.n_u() + 3, "u rows: n+1 plus 3 wrapped");
        assert!(ctrl.iter().all(|r| r.len() == s.n_v()));
        let um: Vec<i64> = sa[8].list().iter().map(V::int).collect();
        let vm: Vec<i64> = sa[9].list().iter().map(V::int).collect();
        assert!(um.iter().all(|&m| m == 1), "u multiplicities all 1");
        assert_eq!((vm[0], vm[vm.len() - 1]), (4, 4), "v clamped");
        let uk = expand(&sa[10].list().iter().map(V::num).collect::<Vec<_>>(), &um);
        let vk = expand(&sa[11].list().iter().map(V::num).collect::<Vec<_>>(), &vm);
        assert_eq!(uk, s.u_knots().extended(), "u knots are bskin's");
        assert_eq!(vk, s.v_knots().knots(), "v knots are bskin's");
        let mut worst = 0.0f64;
        for (u, v) in sample_params(s) {
            worst = worst.max(dist(&eval_open(&uk, &vk, &ctrl, u, v), &s.eval(u, v)));
        }
        assert!(worst < 1e-9, "surface {k}: max deviation {worst:e}");

        // The bound: edges run between their vertices; the seam is S(0, ·); a cap end has no
        // edge; the loop has 4 edges (open ends) or 3 (one cap).
        let bounds = fa[1].list();
        assert_eq!(bounds.len(), 1);
        let (bt, ba) = step.get(bounds[0].id());
        assert_eq!(bt, "FACE_OUTER_BOUND");
        let (_, la) = step.get(ba[1].id());
        let edges = la[1].list();
        let capped = k == 1;
        assert_eq!(edges.len(), if capped { 3 } else { 4 });
        for oe in edges {
            let (ot, oa) = step.get(oe.id());
            assert_eq!(ot, "ORIENTED_EDGE");
            let (et, ea) = step.get(oa[3].id());
            assert_eq!(et, "EDGE_CURVE");
            let (a, b) = (step.vertex(ea[1].id()), step.vertex(ea[2].id()));
            let (ck, cp, closed) = step.curve(ea[3].id());
            let (t0, t1) = (ck[3], ck[ck.len() - 4]);
            assert!(dist(&eval_curve(&ck, &cp, t0), &a) < 1e-9);
            assert!(dist(&eval_curve(&ck, &cp, t1), &b) < 1e-9);
            if closed {
                // A boundary iso-curve v = const: on the surface at every u.
                let v = if dist(&a, &s.eval(0.0, 0.0)) < 1e-9 {
                    s.v_knots().domain().0
                } else {
                    s.v_knots().domain().1
                };
                for q in 0..20 {
                    let u = t0 + (t1 - t0) * q as f64 / 20.0;
                    assert!(dist(&eval_curve(&ck, &cp, u), &s.eval(u, v)) < 1e-9);
                }
            } else {
                for q in 0..=20 {
                    let v = t0 + (t1 - t0) * q as f64 / 20.0;
                    assert!(dist(&eval_curve(&ck, &cp, v), &s.eval(0.0, v)) < 1e-9);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// IGES.

/// Global parameters: Hollerith strings and plain tokens, delimiters ',' and ';'.
fn parse_global(g: &str) -> Vec<String> {
    let b = g.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let st = i;
        while b[i].is_ascii_digit() {
            i += 1;
        }
        if i < b.len() && b[i] == b'H' && i > st {
            let n: usize = g[st..i].parse().unwrap();
            out.push(g[i + 1..i + 1 + n].to_string());
            i += 1 + n;
        } else {
            while b[i] != b',' && b[i] != b';' {
                i += 1;
            }
            out.push(g[st..i].to_string());
        }
        let d = b[i];
        i += 1;
        if d == b';' {
            break;
        }
    }
    out
}

#[test]
fn iges_structure_and_surfaces() {
    let surfs = surfaces();
    let refs: Vec<&SkinnedSurface> = surfs.iter().collect();
    let mut bytes = Vec::new();
    write_iges(&mut bytes, &refs, &meta("t.igs")).unwrap();
    let mut again = Vec::new();
    write_iges(&mut again, &refs, &meta("t.igs")).unwrap();
    assert_eq!(bytes, again, "deterministic bytes");
    let text = String::from_utf8(bytes).unwrap();
    assert!(text.is_ascii());

    // Records: 80 columns, sections in order S G D P T, sequence numbers from 1 in each.
    let mut sections: BTreeMap<char, Vec<&str>> = BTreeMap::new();
    let mut order = String::new();
    for (n, line) in text.lines().enumerate() {
        assert_eq!(line.len(), 80, "line {} has {} columns", n + 1, line.len());
        let letter = line.as_bytes()[72] as char;
        let seq: usize = line[73..].trim().parse().unwrap();
        let recs = sections.entry(letter).or_default();
        assert_eq!(seq, recs.len() + 1, "line {}: sequence number", n + 1);
        recs.push(&line[..72]);
        if !order.ends_with(letter) {
            order.push(letter);
        }
    }
    assert_eq!(order, "SGDPT");
    let t = sections[&'T'][0];
    assert_eq!(
        t.trim_end(),
        format!(
            "S{:>7}G{:>7}D{:>7}P{:>7}",
            sections[&'S'].len(),
            sections[&'G'].len(),
            sections[&'D'].len(),
            sections[&'P'].len()
        )
    );

    let g = parse_global(&sections[&'G'].concat());
    assert_eq!(g.len(), 25, "{g:?}");
    assert_eq!((g[0].as_str(), g[1].as_str()), (",", ";"));
    assert_eq!(g[3], "t.igs");
    assert_eq!(g[13], "2", "unit flag: mm");
    assert_eq!(g[14], "MM");
    assert_eq!(g[22], "11", "IGES 5.3");
    assert_eq!(g[17], "20000101.000000", "fixed date");

    // Directory: two records per entity; its parameter pointer and count match the P lines.
    let d = &sections[&'D'];
    let p = &sections[&'P'];
    assert_eq!(d.len(), 2 * surfs.len());
    let field = |rec: &str, k: usize| rec[8 * k..8 * k + 8].trim().to_string();
    for (k, s) in surfs.iter().enumerate() {
        let (d1, d2) = (d[2 * k], d[2 * k + 1]);
        assert_eq!(field(d1, 0), "128");
        assert_eq!(field(d2, 0), "128");
        let start: usize = field(d1, 1).parse().unwrap();
        let count: usize = field(d2, 3).parse().unwrap();
        let lines = &p[start - 1..start - 1 + count];
        for l in lines {
            assert_eq!(l[65..72].trim(), (2 * k + 1).to_string(), "P back-pointer");
            assert_eq!(&l[64..65], " ");
        }
        let data: String = lines.iter().map(|l| &l[..64]).collect();
        let data = data.trim_end();
        assert!(data.ends_with(';'));
        let toks: Vec<&str> = data
            .trim_end_matches(';')
            .split(',')
            .map(str::trim)
            .collect();
        let int = |i: usize| -> usize { toks[i].parse().unwrap() };
        let num = |i: usize| -> f64 { toks[i].parse().unwrap() };
        assert_eq!(int(0), 128);
        let (k1, k2, m1, m2) = (int(1), int(2), int(3), int(4));
        assert_eq!((m1, m2), (3, 3));
        assert_eq!(
            (int(5), int(6), int(7), int(8), int(9)),
            (1, 0, 1, 1, 0),
            "PROP1..5: closed and periodic in u, polynomial"
        );
        let (nu, nv) = (k1 + 1, k2 + 1);
        assert_eq!((nu, nv), (s.n_u() + 3, s.n_v()));
        let mut at = 10;
        let uk: Vec<f64> = (0..nu + 4).map(|i| num(at + i)).collect();
        at += nu + 4;
        let vk: Vec<f64> = (0..nv + 4).map(|i| num(at + i)).collect();
        at += nv + 4;
        assert!((0..nu * nv).all(|i| num(at + i) == 1.0), "weights 1");
        at += nu * nv;
        // Control points with the u index fastest.
        let mut ctrl = vec![vec![[0.0; 3]; nv]; nu];
        for j in 0..nv {
            for row in ctrl.iter_mut() {
                row[j] = [num(at), num(at + 1), num(at + 2)];
                at += 3;
            }
        }
        let (u0, u1, v0, v1) = (num(at), num(at + 1), num(at + 2), num(at + 3));
        assert_eq!(at + 4, toks.len(), "no trailing parameters");
        let d = s.u_knots().domain();
        assert_eq!((u0, u1), (d[0], d[d.len() - 1]));
        assert_eq!((v0, v1), s.v_knots().domain());
        assert_eq!(uk, s.u_knots().extended());
        assert_eq!(vk, s.v_knots().knots());
        let mut worst = 0.0f64;
        for (u, v) in sample_params(s) {
            worst = worst.max(dist(&eval_open(&uk, &vk, &ctrl, u, v), &s.eval(u, v)));
        }
        assert!(worst < 1e-9, "surface {k}: max deviation {worst:e}");
    }
}

#[test]
fn empty_input_gives_valid_files() {
    let mut step = Vec::new();
    write_step(&mut step, &[], &meta("e.step")).unwrap();
    let s = Step::parse(&String::from_utf8(step).unwrap());
    assert_eq!(s.of_type("OPEN_SHELL").len(), 0);
    assert_eq!(
        s.of_type("SHELL_BASED_SURFACE_MODEL").len(),
        0,
        "no empty set"
    );
    let mut iges = Vec::new();
    write_iges(&mut iges, &[], &meta("e.igs")).unwrap();
    let text = String::from_utf8(iges).unwrap();
    assert!(text.lines().all(|l| l.len() == 80));
    assert!(text.lines().last().unwrap().starts_with("S      1G      "));
}
