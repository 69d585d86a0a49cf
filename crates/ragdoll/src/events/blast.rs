//! Air blast physics (DESIGN §7).
// HELPER-D: replace this stub.
