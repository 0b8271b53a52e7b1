//! Checks on loaded content that name the real cause: coordinates beyond
//! the f32 range of the sweep, grids whose cells were all dropped, text
//! where binary was expected, and control bytes quoted in messages.

/// Coordinates whose half-extent exceeds this cannot be rebased to f32
/// (the sweep's frame) with room for a dot product: `f32::MAX / 4`.
pub const MAX_HALF_EXTENT: f64 = f32::MAX as f64 / 4.0;

/// Refuses a grid whose points do not fit the sweep's f32 frame (centred
/// on the bounding box): names the point, its coordinate and the limit.
pub fn check_f32_range(grid: &crate::grid::Grid) -> Result<(), String> {
    if let Some((i, p)) = grid
        .points
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|x| !x.is_finite()))
    {
        return Err(format!(
            "point {i} has a coordinate that is not finite: {p:?}"
        ));
    }
    if grid.points.is_empty() {
        return Ok(());
    }
    let (lo, hi) = grid.bounds();
    for a in 0..3 {
        let half = (hi[a] - lo[a]) / 2.0;
        if half > MAX_HALF_EXTENT || !half.is_finite() {
            let c = (lo[a] + hi[a]) / 2.0;
            let (i, p) = grid
                .points
                .iter()
                .enumerate()
                .max_by(|x, y| (x.1[a] - c).abs().total_cmp(&(y.1[a] - c).abs()))
                .expect("points");
            return Err(format!(
                "coordinates beyond the f32 range: point {i} has {}={:e}, and the grid spans {:e}..{:e}; \
                 the sweep computes in f32 about the grid's centre, so the span must stay within ±{MAX_HALF_EXTENT:e}",
                ["x", "y", "z"][a],
                p[a],
                lo[a],
                hi[a]
            ));
        }
    }
    Ok(())
}

/// Why a corner-point grid of `cells` cells gave no cells: the classes
/// that took them (`CornerPointReport::class_counts`).
pub fn no_cells_left(cells: usize, classes: &[(&str, usize)]) -> String {
    let get = |k: &str| classes.iter().find(|c| c.0 == k).map_or(0, |c| c.1);
    let mut why = Vec::new();
    if get("inactive") > 0 {
        why.push(format!("{} inactive (ACTNUM 0)", get("inactive")));
    }
    if get("zero_volume_dropped") > 0 {
        why.push(format!(
            "{} dropped as degenerate (zero volume: all corners at the same depth or collapsed)",
            get("zero_volume_dropped")
        ));
    }
    if get("inverted") > 0 {
        why.push(format!("{} inverted", get("inverted")));
    }
    let why = if why.is_empty() {
        "none kept".to_string()
    } else {
        why.join(", ")
    };
    format!("no cells left: of the {cells} cells, {why}")
}

/// True when `head` reads as text: printable ASCII or UTF-8, tabs and line
/// breaks, no NUL.
pub fn looks_like_text(head: &[u8]) -> bool {
    !head.is_empty()
        && head
            .iter()
            .all(|&b| b >= 0x20 || b == b'\n' || b == b'\r' || b == b'\t')
}

/// `s` with control characters (other than line breaks and tabs) written
/// as escapes (`\u{0}`), so that a message quoting binary file content
/// never sends raw control bytes to a terminal.
pub fn escape_control(s: &str) -> String {
    if !s.chars().any(|c| c.is_control() && c != '\n' && c != '\t') {
        return s.to_string();
    }
    s.chars()
        .map(|c| {
            if c.is_control() && c != '\n' && c != '\t' {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}
