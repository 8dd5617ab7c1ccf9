//! Embedded zerotree wavelet coder. (Placeholder: being written.)
