pub mod model;
pub mod ident;
pub mod model_loop;
