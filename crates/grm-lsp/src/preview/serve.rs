//! Serving the preview: computing a request off the executor, ordering
//! and superseding the answers ([`Ticket`]), the `grm/preview` and
//! `grm/pick` handlers and the `grm/previewUpdated` refresh.

use super::*;

/// What [`compute`] made of a request: the document version it analysed
/// (none: the document is not open) and the preview or why there is none.
pub(super) type Computed = (
    Option<i32>,
    std::result::Result<(PreviewResult, PickTable), Failure>,
);

/// Compute a preview off the executor.
pub(super) async fn compute(
    shared: &Arc<Shared>,
    path: PathBuf,
    uri: Uri,
    params: PreviewParams,
    cancel: CancelToken,
) -> Result<Computed> {
    let s = shared.clone();
    tokio::task::spawn_blocking(move || {
        let Some(fa) = s.analyze(&path) else {
            return (None, Err("the document is not open".into()));
        };
        let version = Some(fa.version);
        if let Some(v) = params.version
            && v != fa.version
        {
            return (version, Err(Failure::Stale(fa.version)));
        }
        if params.live {
            // This answer is the live preview of this analysis: a refresh
            // scheduled by the same edit (or the opening) need not build
            // and send it again.
            let key = (
                fa.version,
                (Arc::as_ptr(&fa) as usize, s.edits_generation()),
            );
            let mut sent = s.preview_sent.blocking_lock();
            if sent.get(&path).is_none_or(|&(v, _)| v <= fa.version) {
                sent.insert(path.clone(), key);
            }
        }
        let edits = s.edits_source();
        (
            version,
            build(&fa, &uri, &s.uris(), &edits, &params, Some(&cancel)),
        )
    })
    .await
    .map_err(|e| Error {
        code: ErrorCode::InternalError,
        message: e.to_string().into(),
        data: None,
    })
}

/// A `grm/preview` in progress: its cancel token, registered as the
/// document's live request when it is live (superseding the one before).
/// Dropped with the request's future, before its answer when the client
/// cancelled it (`$/cancelRequest`): then it stops the work.
pub(crate) struct Ticket {
    shared: Arc<Shared>,
    path: PathBuf,
    pub(super) id: u64,
    pub(crate) token: CancelToken,
}

/// Clients whose order of live requests is remembered (per document); past
/// it the memory starts afresh.
pub(super) const MAX_ORDERED_CLIENTS: usize = 256;

impl Ticket {
    /// A `grm/preview`'s ticket. A live one registers as the document's live
    /// preview (its options are `grm/previewUpdated`'s) unless its client
    /// has begun a later one (`client`, `order`): then its ticket is
    /// cancelled at once and it supersedes nothing. Two requests of a client
    /// sent a moment apart may arrive in either order (`grmc view` answers
    /// each connection in a thread of its own); the older never wins.
    pub(crate) fn begin_preview(
        shared: &Arc<Shared>,
        path: &std::path::Path,
        params: &PreviewParams,
    ) -> Ticket {
        if !params.live {
            let ticket = Ticket::begin(shared, path, false);
            shared.previews().remove(path);
            return ticket;
        }
        // Held while registering: one client's requests register in its order.
        let mut orders = shared.live_orders();
        if let (Some(client), Some(order)) = (&params.client, params.order) {
            let key = (path.to_path_buf(), client.clone());
            if orders.get(&key).is_some_and(|&o| o > order) {
                let ticket = Ticket::begin(shared, path, false);
                ticket.token.cancel();
                return ticket;
            }
            if orders.len() >= MAX_ORDERED_CLIENTS && !orders.contains_key(&key) {
                orders.clear();
            }
            orders.insert(key, order);
        }
        // The ticket first: a refresh that sees the live registration below
        // also sees this request running (and leaves the answer to it).
        let ticket = Ticket::begin(shared, path, true);
        shared.previews().insert(path.to_path_buf(), params.clone());
        ticket
    }

    pub(crate) fn begin(shared: &Arc<Shared>, path: &std::path::Path, live: bool) -> Ticket {
        let token = CancelToken::new();
        let id = shared.preview_seq.fetch_add(1, Ordering::Relaxed);
        if live {
            let version = shared.version(path);
            let generation = shared.edits_generation();
            let old = shared
                .running()
                .insert(path.to_path_buf(), (id, token.clone(), version, generation));
            if let Some((_, old, _, _)) = old {
                old.cancel();
            }
        }
        Ticket {
            shared: shared.clone(),
            path: path.to_path_buf(),
            id,
            token,
        }
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        // After the answer the flag is read by no one; before it, the
        // request was dropped, and its blocking work stops at its next check.
        self.token.cancel();
        let mut running = self.shared.running();
        if running
            .get(&self.path)
            .is_some_and(|(id, _, _, _)| *id == self.id)
        {
            running.remove(&self.path);
        }
    }
}

/// Protocol 3: sends the answer's buffers as a blob, where the server has
/// somewhere to send it, just before the message that names it; else (or
/// for base64 text) the answer stays as it is.
pub(crate) fn ship(shared: &Shared, r: &mut PreviewResult) {
    let Some(sink) = &shared.blobs else {
        return;
    };
    let id = shared.blob_seq.fetch_add(1, Ordering::Relaxed);
    if let Some(blob) = r.take_blob(id) {
        sink.send(blob);
    }
}

/// A `grm/preview` that failed on the text of `version` (the program has
/// errors, a limit was hit): RequestFailed, with `data.version` the
/// document version whose text failed, so that a client can tell the
/// failure of an older text (a request sent while the user typed) from the
/// current text's and never shows it over a newer model.
pub(super) fn failed_at(msg: String, version: Option<i32>) -> Error {
    let mut e = failed(msg);
    if let Some(v) = version {
        e.data = Some(serde_json::json!({ "version": v }));
    }
    e
}

/// The answer of a superseded `grm/preview`.
pub(super) fn superseded() -> Error {
    Error {
        code: ErrorCode::ServerError(SERVER_CANCELLED),
        message: "superseded by a newer grm/preview request for this document".into(),
        data: None,
    }
}

impl Backend {
    /// `grm/preview`.
    pub async fn preview(&self, params: PreviewParams) -> Result<PreviewResult> {
        let uri = params.text_document.uri.clone();
        let path = convert::path_of(&uri).ok_or_else(|| failed("not a file URI"))?;
        let ticket = Ticket::begin_preview(&self.shared, &path, &params);
        if ticket.token.is_cancelled() {
            // Its client has begun a later live request for the document.
            return Err(superseded());
        }
        let (version, outcome) = compute(
            &self.shared,
            path.clone(),
            uri,
            params,
            ticket.token.clone(),
        )
        .await?;
        match outcome {
            // Superseded while being built: a newer request answers.
            _ if ticket.token.is_cancelled() => Err(superseded()),
            Ok((mut r, table)) => {
                crate::edits::after_preview(&self.shared, &self.client, &path, &table).await;
                store(&self.shared, path, table);
                // The blob goes out before the answer that names it.
                ship(&self.shared, &mut r);
                Ok(r)
            }
            Err(Failure::Cancelled) => Err(superseded()),
            Err(stale @ Failure::Stale(_)) => Err(Error {
                code: ErrorCode::ContentModified,
                message: stale.to_string().into(),
                data: None,
            }),
            Err(Failure::Msg(msg)) => Err(failed_at(msg, version)),
        }
    }

    /// `f` of the pick table of the last preview of `uri`'s document (an
    /// error when there is none).
    pub(crate) fn with_picks<R>(
        &self,
        uri: &Uri,
        f: impl FnOnce(&PickTable) -> Result<R>,
    ) -> Result<R> {
        let path = convert::path_of(uri).ok_or_else(|| failed("not a file URI"))?;
        let tables = self
            .shared
            .picks
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(t) = tables.get(&path) else {
            return Err(failed("no preview of this document yet"));
        };
        f(t)
    }

    /// `grm/pick`.
    pub async fn pick(&self, params: PickParams) -> Result<Option<PickResult>> {
        self.with_picks(&params.text_document.uri, |t| Self::pick_in(t, &params))
    }

    fn pick_in(t: &PickTable, params: &PickParams) -> Result<Option<PickResult>> {
        if let Some(shape) = &t.shape {
            return Ok(shape.pick(t, params));
        }
        let found = match (params.part, params.triangle, params.bone) {
            (Some(part), Some(tri), _) => t.parts.get(part).and_then(|ps| {
                let i = ps.partition_point(|p| p.0 <= tri);
                let p = ps.get(i.checked_sub(1)?)?;
                (tri < p.0 + p.1).then_some((p.2, p.3))
            }),
            (_, _, Some(b)) => t.bones.get(b as usize).copied(),
            _ => return Err(failed("give `part` and `triangle`, or `bone`")),
        };
        Ok(found.and_then(|(module, origin)| {
            let o = t.origins.get(origin as usize)?;
            let (key, ancestry) = match &t.tree {
                Some(tp) => identity(&tp.0, &tp.1, &t.symbols, module),
                None => (None, Vec::new()),
            };
            Some(PickResult {
                uri: o.uri.clone(),
                range: o.range,
                symbol: o.symbol.clone(),
                version: t.version,
                module,
                key,
                ancestry,
                shape: None,
            })
        }))
    }
}

/// The identity key and ancestry of module `module` of the final string.
pub(super) fn identity(
    tree: &grm_grow::Tree,
    place: &[u32],
    symbols: &[String],
    module: u32,
) -> (Option<String>, Vec<AncestryOut>) {
    let Some(node) = tree.node_of_module(module) else {
        return (None, Vec::new());
    };
    let key = tree
        .nodes
        .get(node as usize)
        .map(|n| grm_grow::json::key_text(n.key));
    let ancestry = tree
        .ancestry(node)
        .into_iter()
        .filter_map(|i| {
            let n = tree.nodes.get(i as usize)?;
            Some(AncestryOut {
                key: grm_grow::json::key_text(n.key),
                symbol: n.symbol.and_then(|s| symbols.get(s as usize)).cloned(),
                child: n
                    .parent
                    .map(|_| place.get(i as usize).copied().unwrap_or(0)),
                production: n.production,
            })
        })
        .collect();
    (key, ancestry)
}

pub(super) fn store(shared: &Shared, path: PathBuf, table: PickTable) {
    let old = shared
        .picks
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .insert(path, table);
    // The table replaced (a building's tree) is freed off the lock and
    // the answer's path.
    if let Some(old) = old {
        drop_later(old);
    }
}

/// After an edit: recompute a live preview of `path` at `version` and send
/// it, unless a newer version exists or was sent.
pub(crate) async fn refresh(shared: &Arc<Shared>, client: &Client, path: PathBuf, version: i32) {
    let Some(params) = shared.previews().get(&path).cloned() else {
        return;
    };
    if shared.version(&path) != Some(version) {
        return;
    }
    // A live request that began at this version or later, and after the
    // last change of an edits file, answers with this analysis (or a newer
    // one) and those edits: not built twice.
    let generation = shared.edits_generation();
    if shared
        .running()
        .get(&path)
        .is_some_and(|&(_, _, v, g)| v >= Some(version) && g >= generation)
    {
        return;
    }
    let uri = params.text_document.uri.clone();
    let options = serde_json::to_value(&params).ok();
    let s = shared.clone();
    let (p, u) = (path.clone(), uri.clone());
    let built = tokio::task::spawn_blocking(move || {
        let fa = s.analyze(&p)?;
        if fa.version != version {
            return None; // a newer text has its own refresh
        }
        // Built from this very analysis and edits already (a second task
        // for the same edit): nothing to send. A changed import makes a new
        // analysis, a changed edits file a new generation.
        let key = (Arc::as_ptr(&fa) as usize, s.edits_generation());
        if s.preview_sent.blocking_lock().get(&p) == Some(&(version, key)) {
            return None;
        }
        let edits = s.edits_source();
        Some((key, build(&fa, &u, &s.uris(), &edits, &params, None)))
    })
    .await;
    let Ok(Some((key, outcome))) = built else {
        return;
    };
    let (result, error) = match outcome {
        Ok((r, table)) => {
            crate::edits::after_preview(shared, client, &path, &table).await;
            store(shared, path.clone(), table);
            (Some(r), None)
        }
        Err(failure) => (None, Some(failure.to_string())),
    };
    // A live request begun since with other options answers for this
    // version (or a newer one) itself: a model of the older options, sent
    // after its answer, would replace the client's current one.
    let live_now = shared
        .previews()
        .get(&path)
        .and_then(|p| serde_json::to_value(p).ok());
    if live_now.is_none() || live_now != options {
        return;
    }
    let mut sent = shared.preview_sent.lock().await;
    // Nor after one of a newer version, or of this version with the
    // edits files of a later generation.
    if shared.version(&path) != Some(version)
        || sent.get(&path).is_some_and(|&(v, k)| {
            v > version || (v, k) == (version, key) || (v == version && k.1 > key.1)
        })
    {
        return;
    }
    sent.insert(path, (version, key));
    let mut result = result;
    if let Some(r) = &mut result {
        ship(shared, r);
    }
    client
        .send_notification::<PreviewUpdated>(PreviewUpdatedParams {
            uri,
            version,
            result,
            error,
        })
        .await;
}
