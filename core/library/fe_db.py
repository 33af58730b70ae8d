"""The results database of `featureextract batch`: SQLite (a file, the default) or PostgreSQL (a
`postgresql://` URL, through psycopg2). One schema for both, versioned: `schema_version` holds the
version applied, MIGRATIONS the steps from one version to the next, each applied in a transaction.

Tables (version 1):
- parts(id, path, hash, faces, triangles): a part file by path and content hash (SHA-256).
- features(id, name, hash, class): a library feature by content hash (feature.json and its files).
- runs(id, started, finished, params, params_hash, library_hash, version, parts, searched, errors):
  one `batch` invocation.
- results(id, run_id, part_id, library_hash, params_hash, ok, error, notes, seconds): one part
  searched with one library and one set of parameters, at most once (UNIQUE(part_id, library_hash,
  params_hash)); an unreadable part is a row with ok = 0 and its one-line error; `notes` names the
  features that could not be searched on a readable part (one line each, e.g. larger than the part).
- matches(id, result_id, feature_id, score, rms_error, scale, mirrored, faces, transform): one
  instance (faces and the 4x4 transform as JSON text).
A part's result row and its matches are written in one transaction, so a batch killed at any
moment and started again leaves every row exactly once.
"""
import json
import os
import time


class DbError(Exception):
    pass


MIGRATIONS = [
    (1, [
        "CREATE TABLE parts (id {pk}, path TEXT NOT NULL, hash TEXT NOT NULL, faces INTEGER, triangles INTEGER, UNIQUE (path, hash))",
        "CREATE TABLE features (id {pk}, name TEXT NOT NULL, hash TEXT NOT NULL UNIQUE, class TEXT)",
        "CREATE TABLE runs (id {pk}, started TEXT NOT NULL, finished TEXT, params TEXT NOT NULL, params_hash TEXT NOT NULL, "
        "library_hash TEXT NOT NULL, version TEXT, parts INTEGER, searched INTEGER, errors INTEGER)",
        "CREATE TABLE results (id {pk}, run_id INTEGER NOT NULL REFERENCES runs(id), part_id INTEGER NOT NULL REFERENCES parts(id), "
        "library_hash TEXT NOT NULL, params_hash TEXT NOT NULL, ok INTEGER NOT NULL, error TEXT, notes TEXT, seconds REAL, "
        "UNIQUE (part_id, library_hash, params_hash))",
        "CREATE TABLE matches (id {pk}, result_id INTEGER NOT NULL REFERENCES results(id), feature_id INTEGER NOT NULL REFERENCES features(id), "
        "score REAL, rms_error REAL, scale REAL, mirrored INTEGER, faces TEXT, transform TEXT)",
        "CREATE INDEX matches_result ON matches (result_id)",
    ]),
]
SCHEMA_VERSION = MIGRATIONS[-1][0]


def connect(url, create=True):
    if url.startswith("postgresql://") or url.startswith("postgres://"):
        return Db(url, "postgresql", create)
    if not create and not os.path.isfile(url):
        raise DbError(f"{url}: no such database file")
    return Db(url, "sqlite", create)


class Db:
    def __init__(self, url, kind, create):
        self.url, self.kind = url, kind
        try:
            if kind == "sqlite":
                import sqlite3
                self.errors = (sqlite3.Error,)
                self.integrity = sqlite3.IntegrityError
                self.con = sqlite3.connect(url, timeout=60)
                self.con.execute("PRAGMA foreign_keys = ON")
                self.con.execute("PRAGMA journal_mode = WAL")
            else:
                import psycopg2
                self.errors = (psycopg2.Error,)
                self.integrity = psycopg2.IntegrityError
                self.con = psycopg2.connect(url)
        except ImportError as e:
            raise DbError(f"{url}: {e} (apt-get install python3-psycopg2)")
        except Exception as e:  # the drivers' own errors: a bad path, a refused connection
            raise DbError(f"{url}: cannot open the database ({e})")
        try:
            self.migrate(create)
        except self.errors as e:
            raise DbError(f"{url}: {e}")

    # SQL is written with SQLite's ? placeholders; psycopg2 takes %s
    def sql(self, s):
        return s if self.kind == "sqlite" else s.replace("?", "%s")

    def execute(self, s, args=()):
        cur = self.con.cursor()
        cur.execute(self.sql(s), args)
        return cur

    def version(self):
        try:
            cur = self.execute("SELECT version FROM schema_version")
            row = cur.fetchone()
            return row[0] if row else 0
        except self.errors:
            self.con.rollback()
            return 0

    def migrate(self, create):
        v = self.version()
        if v > SCHEMA_VERSION:
            raise DbError(f"{self.url}: schema version {v} is newer than this program's {SCHEMA_VERSION}")
        if v == SCHEMA_VERSION:
            return
        if v == 0 and not create:
            raise DbError(f"{self.url}: not a FeatureExtract results database")
        pk = "INTEGER PRIMARY KEY AUTOINCREMENT" if self.kind == "sqlite" else "BIGSERIAL PRIMARY KEY"
        try:
            if v == 0:
                self.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
                self.execute("INSERT INTO schema_version (version) VALUES (0)")
            for version, steps in MIGRATIONS:
                if version <= v:
                    continue
                for s in steps:
                    self.execute(s.format(pk=pk))
                self.execute("UPDATE schema_version SET version = ?", (version,))
            self.con.commit()
        except self.errors:
            self.con.rollback()
            raise

    def close(self):
        self.con.close()

    def insert(self, s, args):
        return self.execute(s + " RETURNING id", args).fetchone()[0]

    # --- batch

    def has_result(self, part_path, part_hash, library_hash, params_hash):
        cur = self.execute("SELECT 1 FROM results r JOIN parts p ON p.id = r.part_id WHERE p.path = ? AND p.hash = ? "
                           "AND r.library_hash = ? AND r.params_hash = ?", (part_path, part_hash, library_hash, params_hash))
        return cur.fetchone() is not None

    def start_run(self, params, params_hash, library_hash, version, parts):
        i = self.insert("INSERT INTO runs (started, params, params_hash, library_hash, version, parts) VALUES (?, ?, ?, ?, ?, ?)",
                        (time.strftime("%Y-%m-%dT%H:%M:%S%z"), params, params_hash, library_hash, version, parts))
        self.con.commit()
        return i

    def finish_run(self, run_id, searched, errors):
        self.execute("UPDATE runs SET finished = ?, searched = ?, errors = ? WHERE id = ?",
                     (time.strftime("%Y-%m-%dT%H:%M:%S%z"), searched, errors, run_id))
        self.con.commit()

    def feature_id(self, name, h, cls):
        row = self.execute("SELECT id FROM features WHERE hash = ?", (h,)).fetchone()
        if row:
            return row[0]
        i = self.insert("INSERT INTO features (name, hash, class) VALUES (?, ?, ?)", (name, h, cls))
        self.con.commit()
        return i

    def store(self, run_id, path, part_hash, library_hash, params_hash, r):
        """One part's outcome, in one transaction. Returns the number of instances stored (0 when the
        row was there already: a second writer, or a retried task)."""
        try:
            res = r.get("result") or {}
            tgt = res.get("target", {})
            row = self.execute("SELECT id FROM parts WHERE path = ? AND hash = ?", (path, part_hash)).fetchone()
            if row:
                part_id = row[0]
                if tgt:
                    self.execute("UPDATE parts SET faces = ?, triangles = ? WHERE id = ?", (tgt.get("faces"), tgt.get("triangles"), part_id))
            else:
                part_id = self.insert("INSERT INTO parts (path, hash, faces, triangles) VALUES (?, ?, ?, ?)",
                                      (path, part_hash, tgt.get("faces"), tgt.get("triangles")))
            # features that could not be searched on this part (larger than it, say), one line each
            notes = "\n".join(f"{f['name']}: {f['error']}" for f in res.get("features", []) if f.get("error")) or None
            result_id = self.insert("INSERT INTO results (run_id, part_id, library_hash, params_hash, ok, error, notes, seconds) "
                                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                                    (run_id, part_id, library_hash, params_hash, 1 if r["ok"] else 0, r.get("error"), notes,
                                     float(r.get("seconds", 0.0))))
            n = 0
            for f in res.get("features", []):
                fid = self.execute("SELECT id FROM features WHERE hash = ?", (f["hash"],)).fetchone()
                if not fid:
                    continue
                for m in f.get("matches", []):
                    self.execute("INSERT INTO matches (result_id, feature_id, score, rms_error, scale, mirrored, faces, transform) "
                                 "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                                 (result_id, fid[0], m.get("score"), m.get("rms_error"), m.get("scale"), 1 if m.get("mirrored") else 0,
                                  json.dumps(m.get("faces", [])), json.dumps(m.get("transform"))))
                    n += 1
            self.con.commit()
            return n
        except self.integrity:
            self.con.rollback()
            return 0
        except self.errors:
            self.con.rollback()
            raise

    # --- report

    def summary(self):
        """The newest result of each part: path, counts per feature, error, seconds."""
        cur = self.execute("SELECT r.id, p.path, r.ok, r.error, r.seconds, r.notes FROM results r JOIN parts p ON p.id = r.part_id "
                           "ORDER BY p.path, r.id")
        latest = {}
        for rid, path, ok, err, sec, notes in cur.fetchall():
            latest[path] = (rid, ok, err, sec, notes)
        out = []
        for path, (rid, ok, err, sec, notes) in sorted(latest.items()):
            counts = {}
            for name, n in self.execute("SELECT f.name, COUNT(*) FROM matches m JOIN features f ON f.id = m.feature_id "
                                        "WHERE m.result_id = ? GROUP BY f.name", (rid,)).fetchall():
                counts[name] = int(n)
            out.append({"path": path, "result_id": rid, "ok": bool(ok), "error": err or "", "notes": notes or "", "seconds": float(sec or 0),
                        "counts": counts})
        return out

    def matches(self):
        cur = self.execute("SELECT p.path, f.name, m.score, m.rms_error, m.scale, m.mirrored, m.faces, m.transform, m.result_id "
                           "FROM matches m JOIN results r ON r.id = m.result_id JOIN parts p ON p.id = r.part_id "
                           "JOIN features f ON f.id = m.feature_id ORDER BY p.path, f.name, m.id")
        return [{"path": a, "feature": b, "score": c, "rms_error": d, "scale": e, "mirrored": bool(g), "faces": h, "transform": t,
                 "result_id": rid} for a, b, c, d, e, g, h, t, rid in cur.fetchall()]
