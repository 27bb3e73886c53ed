//! The dimension-independent physics of bubble packing (thesis chapters 3–4):
//! the interbubble force (§4.2), the damped dynamics (§4.3–4.4), the bubble
//! system and its relaxation (stage 2), population control (§4.7), the neighbour grid,
//! and the constraints that hold bubbles on their entities (§4.5).

pub mod constraint;
pub mod dynamics;
pub mod force;
pub mod grid;
pub mod population;
pub mod relax;
pub mod system;
#[cfg(test)]
pub(crate) mod testing;
