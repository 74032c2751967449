//! A unified diff of a file against its formatted text, for `revelio fmt --check --diff`: the
//! lines to change, with three lines of context, in the format `patch` and `git apply` read.
//!
//! Lines are matched with Myers' O((N+M)·D) algorithm (the same shortest edit script `diff`
//! finds). Formatting changes few lines, so D is small; a file whose lines nearly all change
//! would make the search's trace quadratic, so past [`MAX_EDITS`] edits the whole file is shown
//! as one hunk of removals and additions instead (still a correct patch, just not a minimal one).

/// Lines of context around each change.
pub const CONTEXT: usize = 3;

/// Edits past which the search gives up on a minimal script (memory ~ MAX_EDITS × lines).
const MAX_EDITS: usize = 2_000;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    /// A line of both texts: (old index, new index).
    Same(usize, usize),
    Delete(usize),
    Insert(usize),
}

/// A unified diff that turns `old` into `new` (empty when they are equal). `name` labels both
/// sides (`a/NAME`, `b/NAME`, as git writes them).
pub fn unified(name: &str, old: &str, new: &str) -> String {
    if old == new {
        return String::new();
    }
    let a: Vec<&str> = old.split_inclusive('\n').collect();
    let b: Vec<&str> = new.split_inclusive('\n').collect();
    let ops = edit_script(&a, &b)
        .unwrap_or_else(|| (0..a.len()).map(Op::Delete).chain((0..b.len()).map(Op::Insert)).collect());
    // Lines of each text before each op.
    let mut before = Vec::with_capacity(ops.len());
    let (mut x, mut y) = (0, 0);
    for o in &ops {
        before.push((x, y));
        match o {
            Op::Same(..) => (x, y) = (x + 1, y + 1),
            Op::Delete(_) => x += 1,
            Op::Insert(_) => y += 1,
        }
    }
    let mut out = format!("--- a/{name}\n+++ b/{name}\n");
    for (start, end) in hunks(&ops) {
        write_hunk(&mut out, &ops[start..end], before[start], &a, &b);
    }
    out
}

/// The shortest edit script from `a` to `b`, or `None` past [`MAX_EDITS`] edits.
fn edit_script(a: &[&str], b: &[&str]) -> Option<Vec<Op>> {
    let (n, m) = (a.len() as isize, b.len() as isize);
    let max = (n + m) as usize;
    let offset = max as isize + 1;
    let mut v = vec![0isize; 2 * max + 3];
    let mut trace: Vec<Vec<isize>> = Vec::new();
    let mut found = None;
    'search: for d in 0..=max.min(MAX_EDITS) as isize {
        trace.push(v.clone());
        let mut k = -d;
        while k <= d {
            let i = (k + offset) as usize;
            let mut x = if k == -d || (k != d && v[i - 1] < v[i + 1]) { v[i + 1] } else { v[i - 1] + 1 };
            let mut y = x - k;
            while x < n && y < m && a[x as usize] == b[y as usize] {
                x += 1;
                y += 1;
            }
            v[i] = x;
            if x >= n && y >= m {
                found = Some(d);
                break 'search;
            }
            k += 2;
        }
    }
    let d_end = found?;
    // Walk back through the saved frontiers, from (n, m) to (0, 0).
    let mut ops = Vec::new();
    let (mut x, mut y) = (n, m);
    for d in (1..=d_end).rev() {
        let v = &trace[d as usize];
        let k = x - y;
        let i = (k + offset) as usize;
        let down = k == -d || (k != d && v[i - 1] < v[i + 1]);
        let prev_k = if down { k + 1 } else { k - 1 };
        let prev_x = v[(prev_k + offset) as usize];
        let prev_y = prev_x - prev_k;
        while x > prev_x && y > prev_y {
            x -= 1;
            y -= 1;
            ops.push(Op::Same(x as usize, y as usize));
        }
        if down {
            y -= 1;
            ops.push(Op::Insert(y as usize));
        } else {
            x -= 1;
            ops.push(Op::Delete(x as usize));
        }
    }
    while x > 0 && y > 0 {
        x -= 1;
        y -= 1;
        ops.push(Op::Same(x as usize, y as usize));
    }
    ops.reverse();
    Some(ops)
}

/// Ranges of `ops` to print: each change with up to [`CONTEXT`] equal lines either side,
/// changes closer than twice that joined into one hunk.
fn hunks(ops: &[Op]) -> Vec<(usize, usize)> {
    let changed: Vec<usize> = (0..ops.len()).filter(|&i| !matches!(ops[i], Op::Same(..))).collect();
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &i in &changed {
        let (start, end) = (i.saturating_sub(CONTEXT), (i + CONTEXT + 1).min(ops.len()));
        match out.last_mut() {
            Some(last) if start <= last.1 => last.1 = end,
            _ => out.push((start, end)),
        }
    }
    out
}

/// One hunk: `before` is how many lines of each text come before it.
fn write_hunk(out: &mut String, ops: &[Op], before: (usize, usize), a: &[&str], b: &[&str]) {
    let old_len = ops.iter().filter(|o| !matches!(o, Op::Insert(_))).count();
    let new_len = ops.iter().filter(|o| !matches!(o, Op::Delete(_))).count();
    // 1-based first line; an empty side names the line it follows (0 for none), as diff does.
    let range = |before: usize, len: usize| {
        let first = if len == 0 { before } else { before + 1 };
        if len == 1 { format!("{first}") } else { format!("{first},{len}") }
    };
    out.push_str(&format!("@@ -{} +{} @@\n", range(before.0, old_len), range(before.1, new_len)));
    for o in ops {
        let (mark, line) = match *o {
            Op::Same(x, _) => (' ', a[x]),
            Op::Delete(x) => ('-', a[x]),
            Op::Insert(y) => ('+', b[y]),
        };
        out.push(mark);
        out.push_str(line);
        if !line.ends_with('\n') {
            out.push_str("\n\\ No newline at end of file\n");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Apply a unified diff to `old` the way `patch` does (hunks in order, context checked).
    fn apply(old: &str, diff: &str) -> String {
        let a: Vec<&str> = old.split_inclusive('\n').collect();
        let mut out = String::new();
        let mut next = 0; // next line of `a` not yet copied
        let mut last = b' ';
        let mut lines = diff.split_inclusive('\n').skip(2).peekable();
        while let Some(h) = lines.next() {
            let old_range = h.trim_start_matches("@@ -").split(' ').next().unwrap();
            let mut parts = old_range.split(',');
            let start: usize = parts.next().unwrap().parse().unwrap();
            let len: usize = parts.next().map_or(1, |l| l.parse().unwrap());
            let first = if len == 0 { start } else { start - 1 };
            a[next..first].iter().for_each(|l| out.push_str(l));
            next = first;
            while let Some(l) = lines.peek().filter(|l| !l.starts_with("@@")) {
                let l = *l;
                lines.next();
                let text = &l[1..];
                let mark = l.as_bytes()[0];
                match mark {
                    b' ' => {
                        assert_eq!(a[next].trim_end_matches('\n'), text.trim_end_matches('\n'), "context");
                        out.push_str(a[next]);
                        next += 1;
                    }
                    b'-' => {
                        assert_eq!(a[next].trim_end_matches('\n'), text.trim_end_matches('\n'), "removal");
                        next += 1;
                    }
                    b'+' => out.push_str(text),
                    b'\\' => {
                        // The added line before had no newline: take back the one the diff
                        // format gave it (a context line was copied from `a` as it is).
                        if last == b'+' {
                            out.pop();
                        }
                    }
                    _ => panic!("bad diff line {l:?}"),
                }
                last = mark;
            }
        }
        a[next..].iter().for_each(|l| out.push_str(l));
        out
    }

    #[test]
    fn equal_texts_have_no_diff() {
        assert_eq!(unified("x.rev", "a\nb\n", "a\nb\n"), "");
    }

    #[test]
    fn a_changed_line_shows_with_its_context() {
        let old = "1\n2\n3\n4\nfive\n6\n7\n8\n9\n";
        let new = "1\n2\n3\n4\n5\n6\n7\n8\n9\n";
        assert_eq!(
            unified("d.rev", old, new),
            "--- a/d.rev\n+++ b/d.rev\n@@ -2,7 +2,7 @@\n 2\n 3\n 4\n-five\n+5\n 6\n 7\n 8\n"
        );
    }

    #[test]
    fn far_apart_changes_are_separate_hunks_and_near_ones_join() {
        let old: String = (0..30).map(|i| format!("l{i}\n")).collect();
        let new = old.replace("l2\n", "L2\n").replace("l25\n", "L25\n");
        let d = unified("f", &old, &new);
        assert_eq!(d.matches("@@ -").count(), 2, "{d}");
        let near = old.replace("l2\n", "L2\n").replace("l7\n", "L7\n");
        assert_eq!(unified("f", &old, &near).matches("@@ -").count(), 1);
    }

    #[test]
    fn every_diff_applies_back_to_the_new_text() {
        // Deterministic pseudo-random edits: removals, insertions, changes, at both ends, with
        // and without a final newline.
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) as usize
        };
        for _ in 0..300 {
            let old: Vec<String> = (0..next() % 25).map(|_| format!("{}", next() % 6)).collect();
            let mut new = old.clone();
            for _ in 0..next() % 6 {
                let at = if new.is_empty() { 0 } else { next() % (new.len() + 1) };
                match next() % 3 {
                    0 if at < new.len() => {
                        new.remove(at);
                    }
                    1 if at < new.len() => new[at] = format!("x{}", next() % 4),
                    _ => new.insert(at, format!("y{}", next() % 4)),
                }
            }
            let join = |v: &[String], nl: bool| {
                let mut s = v.join("\n");
                if nl && !s.is_empty() {
                    s.push('\n');
                }
                s
            };
            let (old, new) = (join(&old, next() % 2 == 0), join(&new, next() % 2 == 0));
            let d = unified("r", &old, &new);
            assert_eq!(apply(&old, &d), new, "old {old:?}\nnew {new:?}\ndiff:\n{d}");
        }
    }
}
