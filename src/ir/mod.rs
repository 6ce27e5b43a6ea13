//! The typed IR with computation frequencies (issue 3). Not built yet: the
//! front end stops at the checked AST (`crate::parser`).
