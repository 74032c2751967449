//! "Did you mean": the one rule for suggesting a close name, used by every place that reports an
//! unknown name (the checker, the parser's keywords, concept names on the command line, sim
//! profiles).

/// Levenshtein distance (on chars), case-insensitive so that `weather` finds `Weather`.
pub fn edit_distance(a: &str, b: &str) -> usize {
    strsim::levenshtein(&a.to_lowercase(), &b.to_lowercase())
}

/// The closest candidate within a third of the name's length (at least 1 edit, at most 3);
/// ties go to the candidate seen first, so the result is deterministic.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).clamp(1, 3);
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        if c == name {
            continue;
        }
        let d = edit_distance(name, c);
        if d <= limit && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_and_suggestions() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(suggest("pedestrain", ["Pedestrian", "Cyclist"]), Some("Pedestrian"));
        assert_eq!(suggest("xyz", ["Pedestrian", "Cyclist"]), None);
        assert_eq!(suggest("far", ["far", "near"]), None);
    }
}
