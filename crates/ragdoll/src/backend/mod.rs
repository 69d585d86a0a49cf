//! Physics backends behind one interface.
