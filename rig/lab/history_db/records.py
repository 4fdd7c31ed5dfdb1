"""The SQL of one record, the same on every backend (named ``:parameters``; the driver spells NULL-safe equality,
``tx.same``): a calibration, its sensor and parameters inserted unless the history holds it already, a seal."""

from __future__ import annotations

#: what makes two records the same calibration: the row's columns but when it was recorded or solved and where
#: the files are (``rig solve`` twice of one session writes the same numbers at another ``created`` time)
SAME_RECORD = ("sensor_key", "session_id", "procedure_name", "procedure_sha256", "rig", "software_version",
               "temp_mean_c", "temp_min_c", "temp_max_c", "model", "method", "steps", "residual_rms_g",
               "chi2_per_dof", "verdict", "simulated")
SENSOR_COLUMNS = ("key", "model", "address", "identity", "serial")


class Stored(tuple):
    """``(row id, sensor key)`` of a record; ``already``: the calibration was recorded before (that row's id)."""

    already: bool

    def __new__(cls, cid: int, key: str, already: bool = False) -> "Stored":
        out = super().__new__(cls, (cid, key))
        out.already = already
        return out


def recorded(tx, c: dict, parameters) -> int | None:
    """The id of a row that holds this calibration already (same session, sensor, fit and parameters), or None.
    A session without an id is never taken for another."""
    if c.get("session_id") is None:
        return None
    want = sorted((str(n), v, s, u) for n, v, s, u in parameters)
    rows = tx.execute(f"SELECT id FROM calibrations WHERE {' AND '.join(f'{k} {tx.same} :{k}' for k in SAME_RECORD)} "
                      "ORDER BY id", {k: c.get(k) for k in SAME_RECORD})
    for (cid,) in rows:
        have = tx.execute("SELECT name, value, sigma, unit FROM parameters WHERE calibration_id = :cid", {"cid": cid})
        if sorted(tuple(r) for r in have) == want:
            return cid
    return None


def insert(tx, row: dict) -> Stored:
    """Insert ``row`` (inside the caller's transaction), unless the history holds the same calibration already:
    a record is idempotent (``rig history --record`` or ``rig solve`` twice of one session adds one row), a
    re-solve that differs is a row of its own."""
    s = row["sensor"]
    c = {"sensor_key": s["key"], **row["calibration"]}
    same = recorded(tx, c, row["parameters"])
    if same is not None:
        return Stored(same, s["key"], already=True)
    tx.execute("INSERT INTO sensors (sensor_key, model, address, identity, serial, first_seen) "
               "VALUES (:key, :model, :address, :identity, :serial, :first_seen) ON CONFLICT (sensor_key) DO NOTHING",
               {**{k: s[k] for k in SENSOR_COLUMNS}, "first_seen": row["calibration"]["recorded_at"]})
    cid = tx.insert_id(f"INSERT INTO calibrations ({', '.join(c)}) VALUES ({', '.join(':' + k for k in c)})", c)
    tx.execute_many("INSERT INTO parameters (calibration_id, name, value, sigma, unit) "
                    "VALUES (:cid, :name, :value, :sigma, :unit)",
                    [{"cid": cid, "name": n, "value": v, "sigma": sg, "unit": u} for n, v, sg, u in row["parameters"]])
    return Stored(cid, s["key"])


def set_seal(tx, seal: str, session_path: str, session_id) -> None:
    """Give the rows of a session (its directory and id) that have no seal ``seal`` (JSON)."""
    tx.execute(f"UPDATE calibrations SET seal = :seal WHERE session_path = :path AND session_id {tx.same} :sid "
               "AND seal IS NULL", {"seal": seal, "path": session_path, "sid": session_id})


def stored_row(tx, cid: int) -> dict | None:
    """Calibration ``cid`` as :func:`insert` takes it (``sensor``, ``calibration``, ``parameters``): what the outbox
    sends on; None when there is no such row (another command on this rig sent it meanwhile)."""
    found = tx.execute("SELECT * FROM calibrations WHERE id = :cid", {"cid": cid})
    if not found:
        return None
    c = found[0]
    cal = {k: c[k] for k in c.keys() if k not in ("id", "sensor_key")}
    (s,) = tx.execute("SELECT sensor_key AS key, model, address, identity, serial FROM sensors "
                      "WHERE sensor_key = :key", {"key": c["sensor_key"]})
    params = tx.execute(f"SELECT name, value, sigma, unit FROM parameters WHERE calibration_id = :cid "
                        f"ORDER BY {tx.row_order}", {"cid": cid})
    return {"sensor": {k: s[k] for k in SENSOR_COLUMNS}, "calibration": cal, "parameters": [tuple(p) for p in params]}
