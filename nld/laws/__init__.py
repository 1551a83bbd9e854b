"""Contact and friction laws of a clearance joint (numba functions called by generated kernels):
contact (normal force from penetration), friction (tangential force from slip velocity).
See docs/contact-laws.md."""
