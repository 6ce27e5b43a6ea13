//! The front end: `.shd` text → AST with spans (grammar in `grammar/shade.pest`).
