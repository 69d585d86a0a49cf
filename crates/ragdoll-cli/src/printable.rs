//! Text from a user's file made safe for a terminal before it is printed: a joint named
//! with an ANSI escape would recolour the terminal, a NUL or newline would break lines
//! apart, a right-to-left override would print the rest of the line backwards. Such
//! characters are written as Rust escapes (`\u{1b}`, `\0`, `\n`, `\u{202e}`): visible,
//! and what a user types to find them.

use std::borrow::Cow;

/// Whether `c` changes how a terminal shows what follows rather than being shown: control
/// characters (C0, DEL, C1) and the bidirectional formatting characters.
fn unsafe_char(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with every unsafe character escaped; borrowed when there is none (the usual case).
pub fn shown(text: &str) -> Cow<'_, str> {
    if !text.chars().any(unsafe_char) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if unsafe_char(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_shown_with_their_control_characters_escaped() {
        assert!(matches!(shown("thigh_l"), Cow::Borrowed("thigh_l")));
        assert_eq!(shown("Jos\u{e9} \u{3b1}"), "Jos\u{e9} \u{3b1}");
        assert_eq!(shown("a\u{1b}[31mred"), "a\\u{1b}[31mred");
        assert_eq!(shown("nul\0here\nand\ttab"), "nul\\u{0}here\\nand\\ttab");
        assert_eq!(shown("abc\u{202e}fed"), "abc\\u{202e}fed");
        assert_eq!(shown("c1\u{9b}2J"), "c1\\u{9b}2J");
        let s = shown("\u{1b}\0\n\u{7f}\u{85}\u{2066}");
        assert!(!s.chars().any(unsafe_char), "{s}");
    }
}
