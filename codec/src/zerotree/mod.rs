//! Zerotree → adaptive terrain mesh. (Placeholder: being written.)
