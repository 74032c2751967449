//! Contact sheets: tiles in a grid, each with a caption.
