//! Where a row of a padded plane differs from empty space: the span that the sweeps over the
//! grid (the ordinates, [`crate::transport::cpu`]; the physical occlusion sweep,
//! [`crate::ao::sweep::physical::cpu`]) must compute, outside which every value is the
//! padding's (a transmittance or visibility of exactly 1, an extinction of 0). They keep one
//! per row, so that air costs them next to nothing while the result stays the bytes of
//! sweeping every voxel.

/// A span [start, end) of a padded row's indices; empty when start >= end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

impl Span {
    pub const EMPTY: Span = Span {
        start: usize::MAX,
        end: 0,
    };

    pub fn is_empty(self) -> bool {
        self.start >= self.end
    }

    /// The smallest span holding both.
    pub fn hull(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// The span of `values` (a row's) where `differs` holds, offset by `first`.
    pub fn of(values: &[f32], first: usize, differs: impl Fn(f32) -> bool) -> Span {
        match values.iter().position(|&v| differs(v)) {
            None => Span::EMPTY,
            Some(lo) => {
                let hi = values.iter().rposition(|&v| differs(v)).unwrap_or(lo);
                Span {
                    start: first + lo,
                    end: first + hi + 1,
                }
            }
        }
    }

    /// The span clamped to [lo, hi), as a range (empty when the span is).
    pub fn within(self, lo: usize, hi: usize) -> std::ops::Range<usize> {
        let start = self.start.clamp(lo, hi);
        start..self.end.clamp(start, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_cover_what_differs_and_clamp_to_the_row() {
        let row = [1.0, 1.0, 0.5, 1.0, 0.25, 1.0];
        let span = Span::of(&row, 1, |v| v != 1.0);
        assert_eq!(span, Span { start: 3, end: 6 });
        assert!(Span::of(&row, 1, |v| v > 2.0).is_empty());
        assert_eq!(Span::EMPTY.hull(span), span);
        assert_eq!(
            span.hull(Span { start: 1, end: 2 }),
            Span { start: 1, end: 6 }
        );
        assert_eq!(span.within(4, 5), 4..5);
        assert!(Span::EMPTY.within(1, 7).is_empty());
        assert_eq!(Span { start: 8, end: 9 }.within(1, 7), 7..7);
    }
}
