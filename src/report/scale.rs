//! What the page shows of a domain of hundreds of concepts. A 500 × 500 heatmap is 250 000 cells
//! no one can read (and megabytes of SVG), and a table of every concept or pair buries the few
//! that matter; so past [`HEATMAP_CONCEPTS`] the heatmap draws the concepts most involved in the
//! findings and says how many it leaves out, and the concept and pair tables show their first
//! [`TABLE_ROWS`] rows and say how many more there are. `concepts.csv` and `pairs.csv` hold every
//! row, so nothing is lost, only not drawn.

use super::Findings;
use crate::analysis::{PairRate, PairRates};

/// The most concepts the heatmap draws (a 40 × 40 grid is 720 px wide).
pub const HEATMAP_CONCEPTS: usize = 40;

/// The most rows a table of concepts or pairs shows on the page.
pub const TABLE_ROWS: usize = 100;

/// The concepts the heatmap draws: indices into `f.pairs.concepts`, in its order (highest F(c)
/// first). Every one when they fit; else the [`HEATMAP_CONCEPTS`] most involved in the findings:
/// those of a core first, then those in the most failure modes, then by F(c) and the number of
/// sets (the table's order).
pub fn heatmap_concepts(f: &Findings<'_>) -> Vec<usize> {
    let n = f.pairs.concepts.len();
    if n <= HEATMAP_CONCEPTS {
        return (0..n).collect();
    }
    let in_core = |name: &str| f.cores.iter().any(|c| c.concepts.iter().any(|x| x == name));
    let modes = |i: usize| f.concepts.iter().find(|c| c.concept == f.pairs.concepts[i]).map_or(0, |c| c.failure_modes);
    let mut ranked: Vec<(bool, u32, usize)> = (0..n).map(|i| (in_core(&f.pairs.concepts[i]), modes(i), i)).collect();
    // Most involved first; ties keep the table's order (the index).
    ranked.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.cmp(&a.1)).then(a.2.cmp(&b.2)));
    let mut keep: Vec<usize> = ranked.into_iter().take(HEATMAP_CONCEPTS).map(|r| r.2).collect();
    keep.sort_unstable();
    keep
}

/// The pair rates among the concepts `keep` (indices into `p.concepts`) only.
pub fn restrict(p: &PairRates, keep: &[usize]) -> PairRates {
    PairRates {
        concepts: keep.iter().map(|&i| p.concepts[i].clone()).collect(),
        cells: keep.iter().map(|&i| keep.iter().map(|&j| p.cells[i][j]).collect()).collect(),
    }
}

/// Every evaluated pair (and, on the diagonal, single concept) of `p` as `a + b`, highest rate
/// first, then most sets: the pair table's rows and `pairs.csv`'s.
pub fn ranked_pairs(p: &PairRates) -> Vec<(String, PairRate)> {
    let mut rows = Vec::new();
    for (i, row) in p.cells.iter().enumerate() {
        for (j, c) in row.iter().enumerate().skip(i) {
            let Some(c) = c else { continue };
            let pair = if i == j { p.concepts[i].clone() } else { format!("{} + {}", p.concepts[i], p.concepts[j]) };
            rows.push((pair, *c));
        }
    }
    rows.sort_by(|a, b| b.1.fr.total_cmp(&a.1.fr).then(b.1.n.cmp(&a.1.n)));
    rows
}
