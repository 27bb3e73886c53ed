//! The dimension-independent physics of bubble packing (thesis chapters 3–4):
//! the interbubble force (§4.2), the damped dynamics (§4.3–4.4), the bubble
//! system and its relaxation (stage 2), population control (§4.7), the neighbour grid
//! (and the index of balls of very different sizes),
//! and the constraints that hold bubbles on their entities (§4.5).

/// Upper bound on bubbles one entity may receive; a spacing that asks for
/// more is almost certainly a unit mistake and is reported instead of
/// exhausting memory.
pub const MAX_BUBBLES_PER_ENTITY: usize = 10_000_000;

pub(crate) mod balls;
pub(crate) mod constraint;
pub(crate) mod dynamics;
pub(crate) mod force;
pub(crate) mod grid;
pub(crate) mod population;
pub(crate) mod relax;
pub(crate) mod system;
#[cfg(test)]
pub(crate) mod testing;
