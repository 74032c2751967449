//! The e-BH procedure (Wang & Ramdas, 2022): which of K hypotheses to reject, from one e-value
//! each, so that the expected share of false rejections among the rejections (the false
//! discovery rate) is at most q — under any dependence between the e-values.
//!
//! Sort the e-values from largest down, e₍₁₎ ≥ e₍₂₎ ≥ …; let k* be the largest k with
//! e₍ₖ₎ ≥ K / (q·k); reject the k* hypotheses with the largest e-values (none when no k
//! qualifies). Here the hypotheses are "this candidate core fails at most τ − δ", one per
//! candidate sent to confirmation, and the e-values come from the confirmation's fresh
//! observations only ([`super::cs::e_above`]), so selecting the candidates from the search's
//! data does not inflate them.

/// Which of `e` e-BH rejects at level `q`: a flag per hypothesis, in the input order. Ties at
/// the cut are rejected together (they share a rank's threshold).
pub fn ebh(e: &[f64], q: f64) -> Vec<bool> {
    ebh_weighted(e, &vec![1.0; e.len()], q)
}

/// Weighted e-BH (Wang & Ramdas, 2022, section 5): e-BH on `w_i · e_i`, the weights scaled to
/// sum to K. Weights fixed before the e-values are observed (here: from the search's data, the
/// e-values from fresh observations) keep the false discovery rate at most q under any
/// dependence: a null i is rejected only when w_i·e_i ≥ K / (q·R), so the expected false share
/// is at most q·Σ_null w_i·E\[e_i\] / K ≤ q. A hypothesis with a larger weight needs a smaller
/// e-value; one with weight 0 is never rejected. All weights zero (or none given): plain e-BH.
pub fn ebh_weighted(e: &[f64], w: &[f64], q: f64) -> Vec<bool> {
    debug_assert_eq!(e.len(), w.len());
    let e: Vec<f64> = match scaled_weights(w) {
        Some(w) => e.iter().zip(w).map(|(e, w)| e * w).collect(),
        None => e.to_vec(),
    };
    let k = e.len();
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&a, &b| e[b].total_cmp(&e[a]).then(a.cmp(&b)));
    let cut = (1..=k).rev().find(|&r| e[order[r - 1]] >= k as f64 / (q * r as f64)).unwrap_or(0);
    let mut out = vec![false; k];
    if cut > 0 {
        let bar = e[order[cut - 1]];
        for (i, x) in e.iter().enumerate() {
            out[i] = *x >= bar;
        }
    }
    out
}

/// The weights as weighted e-BH uses them: negative ones as 0, the rest scaled to sum to K (a
/// mean of 1); `None` when none is positive (plain e-BH).
pub fn scaled_weights(w: &[f64]) -> Option<Vec<f64>> {
    let total: f64 = w.iter().map(|x| x.max(0.0)).sum();
    (total > 0.0).then(|| {
        let scale = w.len() as f64 / total;
        w.iter().map(|x| x.max(0.0) * scale).collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Worked by hand, K = 4, q = 0.05. Sorted: 100, 50, 45, 10. Thresholds K/(q·k): 80, 40,
    /// 26.7, 20. 10 < 20 at k = 4; 45 ≥ 26.7 at k = 3: k* = 3, reject the 100, 50 and 45.
    #[test]
    fn hand_worked_example() {
        assert_eq!(ebh(&[100.0, 50.0, 10.0, 45.0], 0.05), vec![true, true, false, true]);
        // Four at 30: 30 ≥ 4/(0.05·4) = 20, all four.
        assert_eq!(ebh(&[30.0; 4], 0.05), vec![true; 4]);
        // One strong e-value among weak ones must beat K/q = 80 alone: 70 does not, though it
        // would pass 1/q = 20 on its own.
        assert_eq!(ebh(&[70.0, 1.0, 1.0, 1.0], 0.05), vec![false; 4]);
        assert_eq!(ebh(&[81.0, 1.0, 1.0, 1.0], 0.05), vec![true, false, false, false]);
        // A step-up: the third clears its bar although 41 alone would not clear 3/0.05 = 60.
        // Sorted 200, 41, 30 against 60, 30, 20: k* = 3.
        assert_eq!(ebh(&[41.0, 200.0, 30.0], 0.05), vec![true; 3]);
        assert!(ebh(&[], 0.05).is_empty());
    }

    /// Weights move the bars: K = 4, q = 0.05, weights 2.5, 0.5, 0.5, 0.5 (sum 4). Plain e-BH
    /// asks 80 of a lone rejection; weighted, the first needs 80 / 2.5 = 32, the others 160.
    #[test]
    fn weights_move_the_bars() {
        let w = [2.5, 0.5, 0.5, 0.5];
        assert_eq!(ebh(&[40.0, 1.0, 1.0, 1.0], 0.05), vec![false; 4]);
        assert_eq!(ebh_weighted(&[40.0, 1.0, 1.0, 1.0], &w, 0.05), vec![true, false, false, false]);
        assert_eq!(ebh_weighted(&[1.0, 100.0, 1.0, 1.0], &w, 0.05), vec![false; 4]);
        // Weights are scaled to sum to K: 5, 1, 1, 1 is the same as 2.5, 0.5, 0.5, 0.5.
        assert_eq!(ebh_weighted(&[40.0, 1.0, 1.0, 1.0], &[5.0, 1.0, 1.0, 1.0], 0.05), vec![true, false, false, false]);
        // Equal weights are plain e-BH; all zero falls back to it.
        let e = [100.0, 50.0, 10.0, 45.0];
        assert_eq!(ebh_weighted(&e, &[3.0; 4], 0.05), ebh(&e, 0.05));
        assert_eq!(ebh_weighted(&e, &[0.0; 4], 0.05), ebh(&e, 0.05));
        // A weight of 0 is never rejected, whatever its e-value.
        assert_eq!(ebh_weighted(&[1e9, 1e9], &[0.0, 1.0], 0.05), vec![false, true]);
    }
}
