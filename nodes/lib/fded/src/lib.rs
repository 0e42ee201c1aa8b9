//! fDED: robot–obstacle distances in depth space (thesis Sec. 5.1.2).
