//! lamina-render
