//! What the caller is told about the levels of a run: levels that lie
//! outside the field's range over the live cells cut nothing (a level `t`
//! cuts a cell iff `lo < t ≤ hi`), which is how depths given for the z axis
//! (world z is minus depth) come back as an empty result.

use crate::field::FieldSpec;

/// The field's name in messages and the statistics: `x`, `-z`, the plane's
/// normal `normal (a, b, c)`, or the property's name.
pub fn field_name(f: &FieldSpec) -> String {
    match f {
        FieldSpec::Axis { axis, negative } => {
            format!(
                "{}{}",
                if *negative { "-" } else { "" },
                ["x", "y", "z"][*axis % 3]
            )
        }
        FieldSpec::Normal(n) => format!("normal ({}, {}, {})", n[0], n[1], n[2]),
        FieldSpec::Property(p) => p.clone(),
    }
}

/// A number for a message: at most three decimals, no trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// The warning for `world` levels (their `local` f32 values beside them)
/// of which some cut nothing because they lie outside the field's local
/// range `range` (over the live cells; `offset` the world value of local
/// 0), or `None` when every level lies inside. For the z axis, when the
/// levels lie above the grid and their negatives reach it, it says that z
/// is minus depth and which levels the depths would be.
pub fn level_warnings(
    field: &FieldSpec,
    range: Option<(f32, f32)>,
    offset: f64,
    world: &[f64],
    local: &[f32],
) -> Option<String> {
    let (lo, hi) = range?;
    let outside = local.iter().filter(|&&t| !(lo < t && t <= hi)).count();
    if outside == 0 || world.is_empty() {
        return None;
    }
    let (wlo, whi) = (lo as f64 + offset, hi as f64 + offset);
    let (first, last) = (world[0], world[world.len() - 1]);
    let span = match world.len() {
        1 => num(first),
        _ => format!("{}..{}", num(first), num(last)),
    };
    let k = world.len();
    let name = field_name(field);
    let mut msg = match outside == k {
        true if k == 1 => format!("level {span} lies outside {name}'s range"),
        true => format!("all {k} levels ({span}) lie outside {name}'s range"),
        false => format!("{outside} of {k} levels ({span}) lie outside {name}'s range"),
    };
    msg.push_str(&format!(
        " {}..{} over the live cells and cut nothing",
        num(wlo),
        num(whi)
    ));
    let z_up = matches!(
        field,
        FieldSpec::Axis {
            axis: 2,
            negative: false
        }
    );
    // Depths: levels above the grid whose negatives reach into it.
    if z_up && first > whi && -first > wlo && -last <= whi {
        msg.push_str(&format!(
            "; z is minus depth: for depths {span} take the levels {}",
            match k {
                1 => num(-first),
                _ => format!("{}..{}", num(-last), num(-first)),
            }
        ));
    }
    Some(msg)
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z: FieldSpec = FieldSpec::Axis {
        axis: 2,
        negative: false,
    };

    fn warn(field: &FieldSpec, range: (f32, f32), world: &[f64]) -> Option<String> {
        let local: Vec<f32> = world.iter().map(|&v| v as f32).collect();
        level_warnings(field, Some(range), 0.0, world, &local)
    }

    #[test]
    fn depths_on_the_z_axis_are_named_with_their_negatives() {
        let w = [5000.0, 5250.0, 5500.0, 5750.0, 6000.0];
        let m = warn(&Z, (-6686.0, -4949.0), &w).unwrap();
        assert_eq!(
            m,
            "all 5 levels (5000..6000) lie outside z's range -6686..-4949 over the live cells \
             and cut nothing; z is minus depth: for depths 5000..6000 take the levels -6000..-5000"
        );
        // Along -z the values are depths already: no hint.
        let down = FieldSpec::Axis {
            axis: 2,
            negative: true,
        };
        let m = warn(&down, (4949.0, 6686.0), &[4000.0, 5000.0]).unwrap();
        assert!(m.starts_with("1 of 2 levels (4000..5000) lie outside -z's range 4949..6686"));
        assert!(!m.contains("depth"), "{m}");
    }

    #[test]
    fn levels_inside_the_range_say_nothing_and_the_ends_follow_the_tie_rule() {
        let p = FieldSpec::Property("PORO".into());
        assert_eq!(warn(&p, (0.0, 1.0), &[0.25, 1.0]), None);
        // t = lo cuts nothing (lo < t fails); t = hi cuts the cells at hi.
        let m = warn(&p, (0.0, 1.0), &[0.0]).unwrap();
        assert!(
            m.starts_with("level 0 lies outside PORO's range 0..1"),
            "{m}"
        );
        assert_eq!(level_warnings(&p, None, 0.0, &[1.0], &[1.0]), None);
    }

    #[test]
    fn field_names_are_words_not_debug_structs() {
        assert_eq!(field_name(&Z), "z");
        assert_eq!(
            field_name(&FieldSpec::Axis {
                axis: 0,
                negative: true
            }),
            "-x"
        );
        assert_eq!(
            field_name(&FieldSpec::Normal([0.0, 0.5, 1.0])),
            "normal (0, 0.5, 1)"
        );
    }
}
