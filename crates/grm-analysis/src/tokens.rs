//! Semantic tokens: every token and comment of a file, classified with the
//! checker's reference index (what a name resolves to) and, for names the
//! index does not cover, by its neighbours (a function call, a setting, a
//! type annotation).

use crate::docs::{self, DocKind};
use crate::shape::Role;
use crate::{FileAnalysis, Span};
use grm_sema::{Def, SymbolKind};
use grm_syntax::lexer::TokKind;

/// What a token is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TokenKind {
    Keyword,
    /// A user module symbol (`A`, `branch`).
    Module,
    /// A built-in turtle, transform or geometry terminal (`F`, `+`, `[`, `cylinder`).
    Turtle,
    /// A parameter bound by a pattern.
    Parameter,
    /// A `const`.
    Constant,
    /// A meta-parameter (`param`).
    MetaParameter,
    /// A built-in function or random draw.
    Function,
    Number,
    String,
    Comment,
    Operator,
    /// A system name.
    System,
    /// A mesh or material name.
    Resource,
    /// A setting, material property or vector field name.
    Property,
    /// A type name.
    Type,
    /// `;` `,` `(` `)` and block braces.
    Punctuation,
    /// A name the checker could not resolve.
    Unresolved,
    /// A word from a fixed set that an operation takes: an axis (`x`,
    /// `xy`), a component kind or selector (`faces`, `front`), a roof kind
    /// (`hip`), a primitive of `insert` (`box`).
    EnumMember,
    /// A semantic tag of a shape command (`split(y, floor)`, `tagged(floor)`).
    Tag,
    /// A value of the shape being rewritten (`scope`, `index`, `count`, `depth`).
    ShapeValue,
}

/// Token modifiers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct TokenModifier {
    /// The token is where the name is defined.
    pub declaration: bool,
    /// A value that cannot change within a run.
    pub readonly: bool,
    /// Part of the language (terminals, built-in functions).
    pub default_library: bool,
}

/// A classified token (spans are in the analysed file, sorted, never
/// overlapping; a multi-line comment is one token).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SemanticToken {
    pub span: Span,
    pub kind: TokenKind,
    pub modifiers: TokenModifier,
}

impl FileAnalysis {
    /// Classify every token and comment of the file.
    pub fn semantic_tokens(&self) -> Vec<SemanticToken> {
        let refs = &self.checked.program.index.refs;
        let p = &self.checked.program;
        let mut out = Vec::with_capacity(self.tokens().len() + self.parsed().comments.len());
        let mut comments = self.parsed().comments.iter().peekable();
        // Refs of this file, in order: walk them alongside the tokens.
        let start = refs.partition_point(|r| r.loc.file < self.root);
        let mut ri = start;
        // The words of shape systems, walked alongside the tokens too.
        let sites = self.shape_sites();
        let mut si = 0;
        for (i, &(kind, span)) in self.tokens().iter().enumerate() {
            while let Some(c) = comments.next_if(|c| c.span.start < span.start) {
                out.push(tok(c.span, TokenKind::Comment, TokenModifier::default()));
            }
            while ri < refs.len()
                && refs[ri].loc.file == self.root
                && refs[ri].loc.span.start < span.start
            {
                ri += 1;
            }
            let r = refs
                .get(ri)
                .filter(|r| r.loc.file == self.root && r.loc.span == span);
            let prev = i.checked_sub(1).map(|j| self.tokens()[j].0);
            let next = self.tokens().get(i + 1).map(|t| t.0);
            while si < sites.len() && sites[si].span.start < span.start {
                si += 1;
            }
            let site = sites.get(si).filter(|s| s.span == span).map(|s| s.role);
            let (k, m) = match (site, r) {
                (Some(role), r) if !role.weak() || r.is_none() => classify_site(role),
                (_, Some(r)) => classify_def(p, r.def, r.is_def),
                (_, None) => self.classify_plain(kind, span, prev, next),
            };
            out.push(tok(span, k, m));
        }
        for c in comments {
            out.push(tok(c.span, TokenKind::Comment, TokenModifier::default()));
        }
        out
    }

    fn classify_plain(
        &self,
        kind: TokKind,
        span: Span,
        prev: Option<TokKind>,
        next: Option<TokKind>,
    ) -> (TokenKind, TokenModifier) {
        use TokKind as T;
        let none = TokenModifier::default();
        let lib = TokenModifier {
            default_library: true,
            ..none
        };
        match kind {
            T::Import
            | T::Const
            | T::Param
            | T::Mesh
            | T::Material
            | T::System
            | T::Module
            | T::Skeleton
            | T::Geometry
            | T::Wrapup
            | T::Axiom
            | T::Ignore
            | T::In
            | T::If
            | T::Then
            | T::Else
            | T::True
            | T::False => (TokenKind::Keyword, none),
            T::Number => (TokenKind::Number, none),
            T::Str => (TokenKind::String, none),
            T::Semi | T::Comma | T::LParen | T::RParen | T::LBrace | T::RBrace => {
                (TokenKind::Punctuation, none)
            }
            T::Ident => {
                let text = self.slice(span);
                let layout_head = |i: Option<TokKind>| i == Some(T::Ident);
                if text == "layout"
                    && layout_head(next)
                    && matches!(prev, Some(T::Semi | T::RBrace) | None)
                {
                    // `layout NAME {`: a contextual keyword.
                    (TokenKind::Keyword, none)
                } else if next == Some(T::LBrace) && layout_head(prev) && self.layouts_at(span) {
                    (
                        TokenKind::System,
                        TokenModifier {
                            declaration: true,
                            ..none
                        },
                    )
                } else if next == Some(T::LParen)
                    && matches!(text, "grid" | "radial" | "geojson" | "lsystem" | "edited")
                    && self.in_layout(span)
                {
                    // A layer source (docs/layout.md).
                    (TokenKind::Function, lib)
                } else if next == Some(T::LParen) && docs::function(text).is_some() {
                    (TokenKind::Function, lib)
                } else if prev == Some(T::Dot) {
                    (TokenKind::Property, none)
                } else if prev == Some(T::Colon) && docs::lookup(text, DocKind::Type).is_some() {
                    (TokenKind::Type, lib)
                } else if next == Some(T::Assign)
                    && matches!(prev, Some(T::Semi | T::LBrace | T::RBrace) | None)
                {
                    (TokenKind::Property, lib)
                } else if matches!(text, "derive" | "sample" | "shape") && prev == Some(T::Assign) {
                    (TokenKind::Keyword, none)
                } else if docs::lookup(text, DocKind::Terminal).is_some() {
                    (TokenKind::Turtle, lib)
                } else {
                    (TokenKind::Unresolved, none)
                }
            }
            // Punctuation that is not an indexed turtle symbol: operators
            // (and `[` `]` of a right context, `{` `}` of a broken string).
            _ => (TokenKind::Operator, none),
        }
    }
}

impl FileAnalysis {
    /// Whether `span` is the name of a `layout` item of this file.
    fn layouts_at(&self, span: Span) -> bool {
        self.checked
            .program
            .layouts
            .iter()
            .any(|l| l.loc.file == self.root && l.loc.span == span)
    }

    /// Whether `span` lies inside a `layout` item of this file.
    fn in_layout(&self, span: Span) -> bool {
        self.checked.program.layouts.iter().any(|l| {
            l.loc.file == self.root && l.span.start <= span.start && span.end <= l.span.end
        })
    }
}

fn tok(span: Span, kind: TokenKind, modifiers: TokenModifier) -> SemanticToken {
    SemanticToken {
        span,
        kind,
        modifiers,
    }
}

/// A word of a shape system (see [`crate::shape`]).
fn classify_site(role: Role) -> (TokenKind, TokenModifier) {
    let lib = TokenModifier {
        default_library: true,
        ..TokenModifier::default()
    };
    match role {
        Role::Op | Role::ValueFn | Role::Lot => (
            if role == Role::Op {
                TokenKind::Turtle
            } else {
                TokenKind::Function
            },
            lib,
        ),
        Role::Axis | Role::CompKind | Role::Selector | Role::RoofKind | Role::Primitive => {
            (TokenKind::EnumMember, lib)
        }
        Role::Tag => (TokenKind::Tag, TokenModifier::default()),
        Role::Nil => (TokenKind::Keyword, TokenModifier::default()),
        Role::Tilde | Role::Percent => (TokenKind::Operator, TokenModifier::default()),
        Role::PartPunct => (TokenKind::Punctuation, TokenModifier::default()),
        Role::Value => (
            TokenKind::ShapeValue,
            TokenModifier {
                readonly: true,
                ..lib
            },
        ),
        Role::Symbol => (TokenKind::Module, TokenModifier::default()),
    }
}

fn classify_def(p: &grm_sema::Program, def: Def, is_def: bool) -> (TokenKind, TokenModifier) {
    let m = TokenModifier {
        declaration: is_def,
        ..TokenModifier::default()
    };
    let ro = TokenModifier {
        readonly: true,
        ..m
    };
    match def {
        Def::Const(_) => (TokenKind::Constant, ro),
        Def::Param(_) => (TokenKind::MetaParameter, ro),
        Def::Mesh(_) | Def::Material(_) => (TokenKind::Resource, ro),
        Def::System(_) => (TokenKind::System, m),
        Def::Binding { .. } => (TokenKind::Parameter, m),
        Def::Symbol(sid, id) => {
            let terminal = p
                .systems
                .get(sid.index())
                .and_then(|s| s.symbols.get(id.index()))
                .is_some_and(|s| s.kind != SymbolKind::User);
            if terminal {
                (
                    TokenKind::Turtle,
                    TokenModifier {
                        default_library: true,
                        ..TokenModifier::default()
                    },
                )
            } else {
                (TokenKind::Module, m)
            }
        }
    }
}
