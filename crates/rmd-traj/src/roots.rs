//! Real roots of low-degree polynomials inside an interval.
//!
//! Roots are isolated between the critical points (roots of the derivative, found
//! recursively), then each bracket with a sign change is narrowed by a safeguarded
//! Newton/bisection iteration to full precision. A critical point where the polynomial vanishes
//! within its rounding error is reported as a (double) root.

use crate::math::{EPS, abs, sqrt};

/// Most roots returned (degree ≤ 6).
pub(crate) const MAX_DEGREE: usize = 6;

/// A small set of sorted real roots.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Roots {
    pub(crate) x: [f64; MAX_DEGREE],
    pub(crate) n: usize,
}

impl Roots {
    pub(crate) const fn new() -> Self {
        Roots {
            x: [0.0; MAX_DEGREE],
            n: 0,
        }
    }

    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.x[..self.n]
    }

    fn push(&mut self, x: f64) {
        if self.n < MAX_DEGREE && x.is_finite() {
            // Keep sorted, skip duplicates.
            for k in 0..self.n {
                if abs(self.x[k] - x) <= 4.0 * EPS * abs(x) {
                    return;
                }
            }
            let mut i = self.n;
            while i > 0 && self.x[i - 1] > x {
                self.x[i] = self.x[i - 1];
                i -= 1;
            }
            self.x[i] = x;
            self.n += 1;
        }
    }
}

/// Value of the polynomial `c` (highest degree first) at `x`.
#[inline]
pub(crate) fn eval(c: &[f64], x: f64) -> f64 {
    let mut r = 0.0;
    for &ci in c {
        r = r * x + ci;
    }
    r
}

/// Rounding-error bound of Horner's scheme at `x`.
#[inline]
fn error_bound(c: &[f64], x: f64) -> f64 {
    let ax = abs(x);
    let mut r = 0.0;
    for &ci in c {
        r = r * ax + abs(ci);
    }
    8.0 * EPS * r
}

/// All real roots of `c` (highest degree first, degree ≤ 6) in `[lo, hi]`, sorted.
pub(crate) fn roots_in(c: &[f64], lo: f64, hi: f64) -> Roots {
    let mut out = Roots::new();
    if !(lo <= hi) || !lo.is_finite() || !hi.is_finite() {
        return out;
    }
    let mut c = c;
    while c.len() > 1 && c[0] == 0.0 {
        c = &c[1..];
    }
    if c.iter().any(|x| !x.is_finite()) {
        return out;
    }
    let n = c.len().saturating_sub(1);
    match n {
        0 => {}
        1 => {
            let x = -c[1] / c[0];
            if x >= lo && x <= hi {
                out.push(x);
            }
        }
        2 => {
            let (a, b, cc) = (c[0], c[1], c[2]);
            let disc = b * b - 4.0 * a * cc;
            let tol = 8.0 * EPS * (b * b + abs(4.0 * a * cc));
            let mut add = |x: f64| {
                if x >= lo && x <= hi {
                    out.push(x);
                }
            };
            if disc >= 0.0 {
                let s = sqrt(disc);
                let q = if b >= 0.0 {
                    -(b + s) / 2.0
                } else {
                    (s - b) / 2.0
                };
                if q != 0.0 {
                    add(q / a);
                    add(cc / q);
                } else {
                    add(0.0);
                }
            } else if -disc <= tol {
                add(-b / (2.0 * a));
            }
        }
        _ => {
            if n > MAX_DEGREE {
                return out;
            }
            let mut d = [0.0; MAX_DEGREE];
            for i in 0..n {
                d[i] = c[i] * (n - i) as f64;
            }
            let crit = roots_in(&d[..n], lo, hi);
            let mut xs = [0.0; MAX_DEGREE + 2];
            let mut m = 0;
            xs[m] = lo;
            m += 1;
            for &x in crit.as_slice() {
                if x > lo && x < hi {
                    xs[m] = x;
                    m += 1;
                }
            }
            xs[m] = hi;
            m += 1;
            let mut fs = [0.0; MAX_DEGREE + 2];
            for k in 0..m {
                fs[k] = eval(c, xs[k]);
            }
            for k in 0..m {
                if fs[k] == 0.0 {
                    out.push(xs[k]);
                }
                if k + 1 < m
                    && fs[k] != 0.0
                    && fs[k + 1] != 0.0
                    && (fs[k] < 0.0) != (fs[k + 1] < 0.0)
                {
                    out.push(bracketed(c, xs[k], xs[k + 1], fs[k], fs[k + 1]));
                }
            }
            // Double roots: a critical point where the value vanishes within rounding.
            for k in 1..m - 1 {
                if fs[k] != 0.0 && abs(fs[k]) <= error_bound(c, xs[k]) {
                    let near = out
                        .as_slice()
                        .iter()
                        .any(|&r| abs(r - xs[k]) <= 1e-7 * (abs(xs[k]) + (hi - lo)));
                    if !near {
                        out.push(xs[k]);
                    }
                }
            }
        }
    }
    out
}

/// Real roots of the monic quartic x⁴ + b·x³ + c·x² + d·x + e in `[lo, hi]`, sorted. Same method
/// as [`roots_in`] (isolation between critical points, safeguarded Newton), specialized: the
/// critical points of the derivative come from a quadratic, the derivative's roots and then the
/// quartic's by Newton from the secant point of each monotone bracket.
pub(crate) fn quartic_roots_in(b: f64, c: f64, d: f64, e: f64, lo: f64, hi: f64) -> Roots {
    let q = [1.0, b, c, d, e];
    let dq = [4.0, 3.0 * b, 2.0 * c, d];
    let mut out = Roots::new();
    if !(lo <= hi) || !lo.is_finite() || !hi.is_finite() || q.iter().any(|x| !x.is_finite()) {
        return out;
    }
    // Most calls have no root in the range: prove that cheaply first (on the whole range, else
    // on its halves). The search below would find nothing there either; a half without a root
    // is left out of the search.
    let mid = 0.5 * (lo + hi);
    if no_root_near(b, c, d, e, mid, 0.5 * (hi - lo)) {
        return out;
    }
    let left_clear = no_root_near(b, c, d, e, 0.5 * (lo + mid), 0.5 * (mid - lo));
    let right_clear = no_root_near(b, c, d, e, 0.5 * (mid + hi), 0.5 * (hi - mid));
    let (lo, hi) = match (left_clear, right_clear) {
        (true, true) => return out,
        (true, false) => (mid, hi),
        (false, true) => (lo, mid),
        (false, false) => (lo, hi),
    };
    // Roots of the derivative (a cubic) in [lo, hi]: between the roots of its derivative.
    let ddq = [12.0, 6.0 * b, 2.0 * c];
    let mut xs = [0.0; 4];
    let mut m = 0;
    xs[m] = lo;
    m += 1;
    let disc = ddq[1] * ddq[1] - 4.0 * ddq[0] * ddq[2];
    if disc > 0.0 {
        let sq = sqrt(disc);
        let (r1, r2) = ((-ddq[1] - sq) / 24.0, (-ddq[1] + sq) / 24.0);
        for r in [r1, r2] {
            if r > lo && r < hi {
                xs[m] = r;
                m += 1;
            }
        }
    }
    xs[m] = hi;
    m += 1;
    let mut crit = [0.0; 3];
    let mut nc = 0;
    let mut fa = eval(&dq, xs[0]);
    for k in 0..m - 1 {
        let fb = eval(&dq, xs[k + 1]);
        if fa == 0.0 {
            if nc < 3 && xs[k] > lo {
                crit[nc] = xs[k];
                nc += 1;
            }
        } else if fb != 0.0 && (fa < 0.0) != (fb < 0.0) && nc < 3 {
            crit[nc] = bracketed(&dq, xs[k], xs[k + 1], fa, fb);
            nc += 1;
        }
        fa = fb;
    }
    // The quartic between its critical points.
    let mut pts = [0.0; 5];
    let mut np = 0;
    pts[np] = lo;
    np += 1;
    for &x in &crit[..nc] {
        if x > lo && x < hi {
            pts[np] = x;
            np += 1;
        }
    }
    pts[np] = hi;
    np += 1;
    let mut fs = [0.0; 5];
    for k in 0..np {
        fs[k] = eval(&q, pts[k]);
    }
    for k in 0..np {
        if fs[k] == 0.0 {
            out.push(pts[k]);
        }
        if k + 1 < np && fs[k] != 0.0 && fs[k + 1] != 0.0 && (fs[k] < 0.0) != (fs[k + 1] < 0.0) {
            out.push(bracketed(&q, pts[k], pts[k + 1], fs[k], fs[k + 1]));
        }
    }
    for k in 1..np - 1 {
        if fs[k] != 0.0 && abs(fs[k]) <= error_bound(&q, pts[k]) {
            let near = out
                .as_slice()
                .iter()
                .any(|&r| abs(r - pts[k]) <= 1e-7 * (abs(pts[k]) + (hi - lo)));
            if !near {
                out.push(pts[k]);
            }
        }
    }
    out
}

/// True if the monic quartic x⁴ + b·x³ + c·x² + d·x + e provably stays away from zero on
/// `[m − r, m + r]`, by more than the rounding of its evaluation there (so the isolation in
/// [`quartic_roots_in`] would report no root, not even a double one). Taylor expansion at `m`:
/// q(m + h) = q(m) + q′(m)·h + q″(m)/2·h² + q‴(m)/6·h³ + h⁴.
fn no_root_near(b: f64, c: f64, d: f64, e: f64, m: f64, r: f64) -> bool {
    let q0 = (((m + b) * m + c) * m + d) * m + e;
    let q1 = ((4.0 * m + 3.0 * b) * m + 2.0 * c) * m + d;
    let q2 = (6.0 * m + 3.0 * b) * m + c;
    let q3 = 4.0 * m + b;
    let swing = (((r + abs(q3)) * r + abs(q2)) * r + abs(q1)) * r;
    // Without the rounding term first: when that already fails, the full test fails too.
    if !(abs(q0) > swing * (1.0 + 1e-9)) {
        return false;
    }
    let x = abs(m) + r;
    let noise = 8.0 * EPS * ((((x + abs(b)) * x + abs(c)) * x + abs(d)) * x + abs(e));
    abs(q0) > (swing + 2.0 * noise) * (1.0 + 1e-9)
}

/// Value, first and second derivative at `x`.
#[inline]
fn eval_d2(c: &[f64], x: f64) -> (f64, f64, f64) {
    let mut r = 0.0;
    let mut d = 0.0;
    let mut d2 = 0.0;
    for &ci in c {
        d2 = d2 * x + d;
        d = d * x + r;
        r = r * x + ci;
    }
    (r, d, 2.0 * d2)
}

/// The root of `c` in `[a, b]` where `c` is monotone and changes sign (`fa` = value at `a`).
/// Laguerre steps (cubically convergent, and unlike Newton not slowed down far from the root of
/// a polynomial dominated by its leading term), kept inside the shrinking bracket by bisection.
fn bracketed(c: &[f64], mut a: f64, mut b: f64, fa: f64, fb: f64) -> f64 {
    let a_neg = fa < 0.0;
    let n = (c.len() - 1) as f64;
    // Start at the secant point (the function is monotone in the bracket).
    let mut x = a - fa * (b - a) / (fb - fa);
    if !(x > a && x < b) {
        x = 0.5 * (a + b);
    }
    for _ in 0..100 {
        let (f, df, d2f) = eval_d2(c, x);
        // At the root to within the rounding of the polynomial's value: no iteration can
        // tell the points of this neighbourhood apart.
        if abs(f) <= error_bound(c, x) {
            return x;
        }
        if (f < 0.0) == a_neg {
            a = x;
        } else {
            b = x;
        }
        let g = df / f;
        let h = g * g - d2f / f;
        let disc = (n - 1.0) * (n * h - g * g);
        let mut next = if disc >= 0.0 {
            let sq = sqrt(disc);
            let den = if g >= 0.0 { g + sq } else { g - sq };
            if den != 0.0 { x - n / den } else { f64::NAN }
        } else if df != 0.0 {
            x - f / df
        } else {
            f64::NAN
        };
        if !(next > a && next < b) {
            next = 0.5 * (a + b);
        }
        if abs(next - x) <= 2.0 * EPS * abs(x) || b - a <= 2.0 * EPS * (abs(a) + abs(b)) {
            return next;
        }
        x = next;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly_from_roots(r: &[f64]) -> [f64; 5] {
        // (x - r0)(x - r1)(x - r2)(x - r3), highest first
        let mut c = [1.0, 0.0, 0.0, 0.0, 0.0];
        for (deg, &ri) in r.iter().enumerate() {
            for k in (1..=deg + 1).rev() {
                c[k] -= ri * c[k - 1];
            }
        }
        c
    }

    #[test]
    fn finds_all_quartic_roots() {
        let c = poly_from_roots(&[-3.0, 0.5, 0.7, 10.0]);
        let r = roots_in(&c, -100.0, 100.0);
        assert_eq!(r.n, 4);
        for (got, want) in r.as_slice().iter().zip([-3.0, 0.5, 0.7, 10.0]) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        let r = roots_in(&c, 0.6, 5.0);
        assert_eq!(r.as_slice().len(), 1);
        assert!((r.x[0] - 0.7).abs() < 1e-14);
    }

    #[test]
    fn quartic_specialization_agrees() {
        for roots in [
            [-3.0, 0.5, 0.7, 10.0],
            [1.0, 1.0, -2.0, 5.0],
            [0.1, 0.2, 0.3, 0.4],
        ] {
            let c = poly_from_roots(&roots);
            let a = roots_in(&c, -100.0, 100.0);
            let b = quartic_roots_in(c[1], c[2], c[3], c[4], -100.0, 100.0);
            assert_eq!(a.n, b.n, "{roots:?}");
            for (x, y) in a.as_slice().iter().zip(b.as_slice()) {
                assert!((x - y).abs() < 1e-9, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn double_root_is_reported() {
        let c = poly_from_roots(&[1.0, 1.0, -2.0, 5.0]);
        let r = roots_in(&c, -10.0, 10.0);
        assert!(
            r.as_slice().iter().any(|x| (x - 1.0).abs() < 1e-7),
            "{:?}",
            r.as_slice()
        );
    }

    #[test]
    fn quadratic_and_linear() {
        let r = roots_in(&[1.0, -3.0, 2.0], -10.0, 10.0);
        assert_eq!(r.as_slice(), &[1.0, 2.0]);
        let r = roots_in(&[0.0, 2.0, -4.0], -10.0, 10.0);
        assert_eq!(r.as_slice(), &[2.0]);
    }
}
