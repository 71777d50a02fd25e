//! Values that must lie in 0..1: material properties and `color(r, g, b)`.
//! One check for both: a value that is not a finite number is an error
//! (E0212: glTF and MTL cannot hold one), one outside 0..1 a warning
//! (W0010: the model clamps it). Colours written on a 0..255 scale (whole
//! numbers up to 255, one of at least 10) get the division by 255 as the fix.

use grm_diag::{Code, Diagnostic, FileId, Span};

/// What is checked, for the messages.
pub(crate) struct UnitValue<'a> {
    pub file: FileId,
    /// The primary span: what a fix replaces.
    pub span: Span,
    /// "`color` of material `bark`", "this colour".
    pub subject: &'a str,
    /// The value (one float, or a colour's three components).
    pub xs: &'a [f64],
    /// Source text for values in place of `span` (`0.5`, `rgb(1, 0, 0)`,
    /// `color(1, 0, 0)`).
    pub write: &'a dyn Fn(&[f64]) -> String,
    /// Whether the value is a constant (a fix may replace it); otherwise it
    /// was evaluated with the meta-parameters' defaults.
    pub constant: bool,
    /// "material values", "colours".
    pub kind: &'a str,
}

/// A value as the language's 32-bit floats print it.
pub(crate) fn show_f32(x: f64) -> String {
    format!("{}", x as f32)
}

/// The diagnostic for a value out of 0..1, if it is.
pub(crate) fn check(v: &UnitValue<'_>) -> Option<Diagnostic> {
    let shown = (v.write)(v.xs);
    let note = |d: Diagnostic| {
        if v.constant {
            d
        } else {
            d.with_note("evaluated with the meta-parameters' default values")
        }
    };
    if v.xs.iter().any(|x| !x.is_finite()) {
        let d = Diagnostic::new(
            Code::InvalidUnitValue,
            format!("{} has no finite value", v.subject),
            v.file,
            v.span,
            format!("this is {shown}"),
        )
        .with_help(format!(
            "{} lie in 0..1: give it a value from 0 to 1",
            v.kind
        ));
        return Some(note(d));
    }
    if v.xs.iter().all(|x| (0.0..=1.0).contains(x)) {
        return None;
    }
    let clamped: Vec<f64> = v.xs.iter().map(|x| x.clamp(0.0, 1.0)).collect();
    let to = (v.write)(&clamped);
    // `color(2, 0, 0)` is more likely an overshoot than a 0..255 colour.
    let bytes = v.xs.len() == 3
        && v.xs
            .iter()
            .all(|&x| x.fract() == 0.0 && (0.0..=255.0).contains(&x))
        && v.xs.iter().any(|&x| x >= 10.0);
    let help = if !v.constant {
        format!(
            "{} lie in 0..1: keep this one in range for every value of the \
             meta-parameters (e.g. with `clamp`)",
            v.kind
        )
    } else if bytes {
        // Three decimals: as close as 8-bit colour resolves.
        let scaled: Vec<f64> =
            v.xs.iter()
                .map(|x| (x / 255.0 * 1000.0).round() / 1000.0)
                .collect();
        format!(
            "{} lie in 0..1; for 0..255 values divide by 255: write `{}`",
            v.kind,
            (v.write)(&scaled)
        )
    } else {
        format!("{} lie in 0..1: write `{to}`", v.kind)
    };
    let d = Diagnostic::new(
        Code::UnitValueClamped,
        format!("{} is outside 0..1", v.subject),
        v.file,
        v.span,
        format!("this is {shown}; the model uses {to}"),
    )
    .with_help(help);
    Some(note(d))
}

/// `rgb(a, b, c)` / `a` as source text.
pub(crate) fn write_value(xs: &[f64]) -> String {
    match xs {
        [x] => show_f32(*x),
        _ => format!("rgb({})", join(xs)),
    }
}

/// `a, b, c`.
pub(crate) fn join(xs: &[f64]) -> String {
    xs.iter()
        .map(|&x| show_f32(x))
        .collect::<Vec<_>>()
        .join(", ")
}
