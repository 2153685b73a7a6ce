//! What the LOD summary says of one peer's curve when its data show a property of the peer's
//! own drawing rule, not of our scoring: py3dtiles-lod's flat PSNR (its wrapper draws a tile's
//! points as splats of max(R, geometric error / 2) over an additive tileset). The text is
//! written only when the rows show the flat curve, so it never explains what did not happen.

use super::Row;
use crate::experiments::rules::curve::IDENTICAL_PSNR;
use crate::output::distinct;

/// `n` with a comma between thousands ("871,414").
pub fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// What the summary says of py3dtiles-lod's flat curve, when it ran on `ds` and its settings'
/// mean PSNRs lie within 0.5 dB at some distance while one draws every point and another
/// under a tenth of them.
pub fn py3dtiles_note(rows: &[Row], ds: &str, distances: &[f64]) -> Option<String> {
    const PEER: &str = "py3dtiles-lod";
    let n = rows
        .iter()
        .filter(|r| r.dataset == ds)
        .map(|r| r.n_points.max(r.points_rendered))
        .max()?;
    for &d in distances {
        let at: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                r.dataset == ds
                    && r.distance == d
                    && r.method == PEER
                    && r.status == "ok"
                    && r.psnr < IDENTICAL_PSNR
            })
            .collect();
        // Per setting: mean points and mean PSNR over the views.
        let settings = distinct(at.iter().map(|r| r.params.as_str()));
        let means: Vec<(f64, f64)> = settings
            .iter()
            .map(|p| {
                let of: Vec<&&Row> = at.iter().filter(|r| &r.params == p).collect();
                let k = of.len() as f64;
                (
                    of.iter().map(|r| r.points_rendered as f64).sum::<f64>() / k,
                    of.iter().map(|r| r.psnr).sum::<f64>() / k,
                )
            })
            .collect();
        if means.len() < 2 {
            continue;
        }
        let fold = |f: fn(f64, f64) -> f64, init: f64, k: usize| {
            means
                .iter()
                .map(|m| if k == 0 { m.0 } else { m.1 })
                .fold(init, f)
        };
        let (fewest, most) = (fold(f64::min, f64::INFINITY, 0), fold(f64::max, 0.0, 0));
        let (lo, hi) = (
            fold(f64::min, f64::INFINITY, 1),
            fold(f64::max, f64::NEG_INFINITY, 1),
        );
        if most < n as f64 || hi - lo > 0.5 || fewest * 10.0 > n as f64 {
            continue;
        }
        return Some(format!(
            "{PEER} stays at {} (means over the views) at distance ×{d} \
             whether it draws {} or all {} points. This is how the peer draws, not a scoring \
             fault: py3dtiles writes an additive (`ADD`) tileset, each point stored once in the \
             coarsest tile that keeps it, so a cut draws every coarse tile on the way to the \
             leaves, and the wrapper draws a tile's points as splats of radius \
             max(R, geometric error / 2) (Cesium's point attenuation, without Cesium's cap of \
             `maximumAttenuation` pixels). The coarse tiles' large discs lie in front of the \
             fine points and cover them (the strip above: round blobs at every setting), so \
             drawing more points changes nothing; capping the splats at `sse_px` pixels, as \
             Cesium does, would change its curve.\n\n",
            if format!("{lo:.1}") == format!("{hi:.1}") {
                format!("{lo:.1} dB")
            } else {
                format!("{lo:.1} to {hi:.1} dB")
            },
            thousands(fewest.round() as usize),
            thousands(n)
        ));
    }
    None
}
