//! Numbers in plain text: three significant figures, the form every sentence of the diagnosis
//! and the fleet evidence uses, and lists of numbers in messages.

/// `x` with three significant figures, without an exponent between 10⁻⁴ and 10⁶ (`0.00755`,
/// `21738`, `-94.5`), with one outside (`2.50e-6`); zero and non-finite values as Rust prints them.
pub fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{x:.2e}");
    }
    let decimals = (2 - mag).max(0) as usize;
    format!("{x:.decimals$}")
}

/// Numbers as a plain comma-separated list in brackets, each as Rust prints it: `[14.94, 11.73,
/// 9.04]` (for messages naming a list from a file).
pub fn list(xs: &[f64]) -> String {
    let items: Vec<String> = xs.iter().map(|x| x.to_string()).collect();
    format!("[{}]", items.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_three_significant_figures() {
        assert_eq!(sig3(0.007548), "0.00755");
        assert_eq!(sig3(21737.52), "21738");
        assert_eq!(sig3(-94.47), "-94.5");
        assert_eq!(sig3(1.5777), "1.58");
        assert_eq!(sig3(2.5e-6), "2.50e-6");
        assert_eq!(list(&[14.94, 1.0, 0.5]), "[14.94, 1, 0.5]");
    }
}
