"""The report's style sheet, carried inside the page (system fonts only: nothing to download)."""

CSS = """
:root { --text: #1f2328; --muted: #59636e; --line: #d1d9e0; --soft: #f6f8fa; --accent: #0b4f8a;
  --pass: #1a7f37; --pass-bg: #dafbe1; --fail: #cf222e; --fail-bg: #ffebe9; --none: #0969da; --none-bg: #ddf4ff;
  --warn: #9a6700; --warn-bg: #fff8c5; }
* { box-sizing: border-box; }
html { background: #eef1f4; }
body { margin: 0; color: var(--text); font: 14px/1.5 system-ui, -apple-system, "Segoe UI", "DejaVu Sans",
  "Liberation Sans", Arial, sans-serif; }
code { font-family: ui-monospace, "DejaVu Sans Mono", "Liberation Mono", monospace; font-size: 12.5px; }
header.top { background: #0f2a44; color: #fff; padding: 22px 40px 0; }
header.top .kicker { text-transform: uppercase; letter-spacing: .12em; font-size: 11px; color: #9fc3e6; }
header.top h1 { margin: 4px 0 2px; font-size: 26px; font-weight: 600; }
header.top .sub { margin: 0 0 14px; color: #c9d7e6; }
header.top .sub code { color: #fff; }
header.top nav { display: flex; gap: 2px; flex-wrap: wrap; }
header.top nav a { color: #c9d7e6; text-decoration: none; padding: 7px 12px; border-radius: 6px 6px 0 0;
  font-size: 13px; }
header.top nav a:hover { background: #1d4166; color: #fff; }
main { max-width: 1180px; margin: 0 auto; padding: 24px 40px 8px; }
section { background: #fff; border: 1px solid var(--line); border-radius: 8px; padding: 18px 24px 20px;
  margin: 0 0 20px; }
section h2 { margin: 0 0 10px; font-size: 18px; font-weight: 600; color: var(--accent); }
section h3 { margin: 0 0 8px; font-size: 14px; font-weight: 600; }
section.verdict-section { padding: 0; overflow: hidden; }
section.verdict-section > .alert, section.verdict-section > table { margin: 0 24px 16px; width: calc(100% - 48px); }
.verdict { display: flex; gap: 22px; align-items: flex-start; border-left: 8px solid; padding: 18px 24px;
  margin-bottom: 14px; }
.verdict .badge { flex: none; min-width: 128px; text-align: center; font-size: 24px; font-weight: 700;
  letter-spacing: .04em; padding: 16px 14px; border-radius: 6px; color: #fff; }
.verdict .headline { margin: 2px 0 6px; font-size: 17px; font-weight: 600; }
.verdict-pass { border-color: var(--pass); } .verdict-pass .badge { background: var(--pass); }
.verdict-fail { border-color: var(--fail); } .verdict-fail .badge { background: var(--fail); }
.verdict-none { border-color: var(--none); } .verdict-none .badge { background: var(--none); font-size: 19px; }
.verdict .verdict-body { flex: 1; }
ul.failed { margin: 4px 0 10px; padding-left: 20px; color: var(--fail); font-weight: 600; }
.alert { border-radius: 6px; padding: 10px 18px; border: 1px solid; }
.alert ul { margin: 4px 0; padding-left: 20px; } .alert p { margin: 4px 0 0; }
.alert-incomplete { background: var(--fail-bg); border-color: var(--fail); color: #82071e; }
.alert-incomplete strong { letter-spacing: .05em; }
.alert-warning { background: var(--warn-bg); border-color: #d4a72c; color: #4d2d00; }
dl.facts { display: grid; grid-template-columns: max-content 1fr; gap: 3px 16px; margin: 0; }
dl.facts dt { color: var(--muted); } dl.facts dd { margin: 0; overflow-wrap: anywhere; }
.cards { display: grid; grid-template-columns: repeat(2, minmax(0, 1fr)); gap: 14px; }
.card { background: var(--soft); border: 1px solid var(--line); border-radius: 6px; padding: 12px 16px; }
table.data { border-collapse: collapse; width: 100%; margin: 6px 0 8px; font-variant-numeric: tabular-nums; }
table.data th, table.data td { padding: 5px 10px; border-bottom: 1px solid var(--line); text-align: left;
  vertical-align: top; }
table.data thead th { background: var(--soft); font-weight: 600; font-size: 12.5px; color: var(--muted);
  border-bottom: 2px solid var(--line); }
table.data .num { text-align: right; white-space: nowrap; }
table.data tr.group th { background: #fff; color: var(--accent); font-size: 12px; text-transform: uppercase;
  letter-spacing: .08em; padding-top: 12px; }
table.data tbody tr.param:nth-child(even) td, table.data tbody tr:nth-child(even) td { background: #fafbfc; }
.nowrap { white-space: nowrap; }
.ok { color: var(--pass); font-weight: 600; } .bad { color: var(--fail); font-weight: 600; }
.tag { background: var(--none-bg); color: var(--none); border-radius: 10px; padding: 0 8px; font-size: 11px;
  margin-left: 4px; white-space: nowrap; }
figure { margin: 12px 0 6px; } figure img { width: 100%; height: auto; border: 1px solid var(--line);
  border-radius: 6px; } figcaption { color: var(--muted); font-size: 12px; margin-top: 4px; }
p.note { margin: 6px 0; } p.muted { color: var(--muted); margin: 4px 0 8px; }
p.summary { font-weight: 600; margin: 6px 0; } p.source { color: var(--muted); font-size: 12px; }
details { margin-top: 8px; } summary { cursor: pointer; color: var(--accent); }
footer { max-width: 1180px; margin: 0 auto; padding: 4px 40px 28px; color: var(--muted); font-size: 12px; }
@media print { html { background: #fff; } header.top nav { display: none; } section { break-inside: avoid; }
  main { padding: 12px 0; } }
"""
