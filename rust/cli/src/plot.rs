//! Plots: tracks over the floor plan and error CDFs (PNG).
