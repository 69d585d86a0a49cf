//! Events that act on ragdolls. So far: explosion blast waves (`blast.rs`: the physics of
//! the air blast, Kingery–Bulmash curves and Friedlander histories, DESIGN §7).

pub mod blast;
