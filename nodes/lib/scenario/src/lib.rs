//! Simulated experiments of the reactive DS controller (thesis Sec. 5.1.1, 5.1.3).
