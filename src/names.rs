//! Enumerations by the names users type, on the command line and in scene files: each such
//! enumeration lists its `(name, value)` pairs once and parses through [`parse_name`], so an
//! unknown name's error lists every accepted one.

use crate::error::{Error, Result};

/// The value named `name` among `choices`; `what` names the setting in the error.
pub fn parse_name<T: Copy>(what: &str, name: &str, choices: &[(&str, T)]) -> Result<T> {
    choices
        .iter()
        .find(|(choice, _)| *choice == name)
        .map(|&(_, value)| value)
        .ok_or_else(|| {
            let names: Vec<&str> = choices.iter().map(|(choice, _)| *choice).collect();
            Error::param(
                what,
                format!("unknown '{name}': one of {}", names.join(", ")),
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_parses_and_an_unknown_one_lists_the_choices() {
        let choices = [("near", 1), ("far", 2)];
        assert_eq!(parse_name("reach", "far", &choices).unwrap(), 2);
        let err = parse_name("reach", "Far", &choices)
            .unwrap_err()
            .to_string();
        assert_eq!(err, "invalid `reach`: unknown 'Far': one of near, far");
    }
}
