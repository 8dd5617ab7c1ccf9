//! The line behind an OBJ parse error. tobj names the kind of statement that failed ("face
//! parse error", "face vertex index out of bounds") but not where, which in a million-line
//! export is no help. Once tobj has failed, the statements are read again here by the rule
//! its error names, to point at the first line that breaks it.

/// Echoed lines are cut to this many characters (a 20 MB line is possible).
const ECHO: usize = 80;

/// Where and why, for the errors that come from one statement; `None` for the others or if
/// no line breaks the rule (then tobj's words stand alone).
pub(super) fn locate(text: &str, error: &tobj::LoadError) -> Option<String> {
    use tobj::LoadError as E;
    let total_v = text.lines().filter(|l| first_word(l) == Some("v")).count();
    let mut v_so_far = 0;
    for (k, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let why = match (words.next(), error) {
            (Some("v"), E::PositionParseError | E::ColorParseError | E::ScalingByZeroError) => {
                bad_vertex(words.collect())
            }
            (Some("f"), E::FaceParseError) => words
                .find(|w| index_of(w).is_none())
                .map(|w| format!("`{}` is not a vertex index", cut(w))),
            (Some("f"), E::FaceVertexOutOfBounds) => words
                .filter_map(index_of)
                .find_map(|i| out_of_bounds(i, v_so_far, total_v)),
            _ => None,
        };
        if let Some(why) = why {
            return Some(format!("line {} `{}`: {why}", k + 1, cut(line.trim())));
        }
        if first_word(line) == Some("v") {
            v_so_far += 1;
        }
    }
    None
}

fn first_word(line: &str) -> Option<&str> {
    line.split_whitespace().next()
}

/// What is wrong with a `v` statement's numbers, if anything: tobj takes x y z, then a w
/// (not 0) or an r g b.
fn bad_vertex(numbers: Vec<&str>) -> Option<String> {
    if let Some(w) = numbers.iter().find(|w| w.parse::<f64>().is_err()) {
        return Some(format!("`{}` is not a number", cut(w)));
    }
    match numbers.len() {
        3 | 6 => None,
        4 if numbers[3].parse::<f64>() == Ok(0.0) => {
            Some("a w of 0 would divide the position by zero".into())
        }
        4 => None,
        n => Some(format!(
            "{n} numbers; a vertex is x y z, then a w or an r g b (3, 4 or 6)"
        )),
    }
}

/// The vertex index of a face corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`), as tobj reads it.
fn index_of(corner: &str) -> Option<isize> {
    let mut parts = corner.split('/');
    let v = parts.next()?.parse().ok()?;
    let rest: Vec<&str> = parts.collect();
    (rest.len() <= 2
        && rest
            .iter()
            .all(|p| p.is_empty() || p.parse::<isize>().is_ok()))
    .then_some(v)
}

/// Why index `i` names no vertex, with `before` vertices above its line and `total` in all.
fn out_of_bounds(i: isize, before: usize, total: usize) -> Option<String> {
    match i {
        0 => Some("OBJ counts vertices from 1, so 0 names none".into()),
        i if i > 0 && i.unsigned_abs() > total => {
            Some(format!("vertex {i}, but the file has {total}"))
        }
        i if i < 0 && i.unsigned_abs() > before => Some(format!(
            "vertex {i} counts back past the first ({before} above this line)"
        )),
        _ => None,
    }
}

/// At most [`ECHO`] characters of `s`, marked when cut.
fn cut(s: &str) -> String {
    match s.char_indices().nth(ECHO) {
        Some((at, _)) => format!("{}…", &s[..at]),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::locate;
    use tobj::LoadError as E;

    const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

    #[test]
    fn each_kind_of_error_points_at_its_line() {
        let cases = [
            (
                "f 0 1 2",
                E::FaceVertexOutOfBounds,
                "line 4 `f 0 1 2`: OBJ counts vertices from 1",
            ),
            (
                "f 1 2 9",
                E::FaceVertexOutOfBounds,
                "line 4 `f 1 2 9`: vertex 9, but the file has 3",
            ),
            (
                "f -1 -2 -4",
                E::FaceVertexOutOfBounds,
                "vertex -4 counts back past the first (3 above",
            ),
            (
                "f 1 2 x7",
                E::FaceParseError,
                "line 4 `f 1 2 x7`: `x7` is not a vertex index",
            ),
            (
                "f 1 2 99999999999999999999",
                E::FaceParseError,
                "`99999999999999999999` is not a vertex index",
            ),
            (
                "f 1/1/1/1 2 3",
                E::FaceParseError,
                "`1/1/1/1` is not a vertex index",
            ),
            (
                "v 1 2",
                E::PositionParseError,
                "line 4 `v 1 2`: 2 numbers; a vertex is x y z",
            ),
            ("v 1 2 3 4 5", E::ColorParseError, "5 numbers"),
            ("v 1 two 3", E::PositionParseError, "`two` is not a number"),
            ("v 1 2 3 0", E::ScalingByZeroError, "a w of 0"),
        ];
        for (last, error, told) in cases {
            let text = format!("{TRI}{last}\n");
            let at = locate(&text, &error).unwrap_or_else(|| panic!("{last}: not found"));
            assert!(at.contains(told), "{last}: {at}");
        }
    }

    #[test]
    fn good_lines_and_other_errors_are_not_blamed() {
        let good =
            format!("{TRI}v 1 1 1 1\nv 2 2 2 0.5 0.5 0.5\nf 1 2 3\nf -1 -2 -3\nf 1/1 2//2 3/3/3\n");
        for error in [
            E::FaceVertexOutOfBounds,
            E::FaceParseError,
            E::PositionParseError,
            E::ColorParseError,
        ] {
            assert_eq!(locate(&good, &error), None, "{error}");
        }
        // The first offending line, not a later one; an error of another statement kind
        // finds nothing to blame.
        let two = format!("{TRI}f 1 2 7\nf 0 1 2\n");
        assert!(locate(&two, &E::FaceVertexOutOfBounds)
            .unwrap()
            .starts_with("line 4 "));
        assert_eq!(locate(&two, &E::PositionParseError), None);
        assert_eq!(locate(&two, &E::ReadError), None);
    }

    #[test]
    fn a_long_line_is_cut_in_the_message() {
        let long = format!("{TRI}f 1 2 {}\n", "9".repeat(10_000));
        let at = locate(&long, &E::FaceParseError).unwrap();
        assert!(at.len() < 300 && at.contains('…'), "{}", at.len());
    }
}
