//! Body-segment data: de Leva (1996) mass fractions and anatomical joint ranges.
// HELPER-C: replace this stub.
