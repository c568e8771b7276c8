//! Solis-Wets random search (under construction).
