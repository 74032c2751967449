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
}
