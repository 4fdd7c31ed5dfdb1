"""Adversarial campaign: generated bad inputs against every file-reading command and option, plus process faults.

    python benchmarks/bench_adversarial.py            # full campaign (~670 inputs, 23 signal trials, concurrency)
    python benchmarks/bench_adversarial.py --quick    # ~85 inputs, 5 signal trials, one concurrent resume
    python benchmarks/bench_adversarial.py --jobs 2 --seed 2026 --filter samples
    python -m benchmarks.adversarial --quick          # the same, from the repository's folder

One module per attack class, a shared runner and report:

=================  ==========================================================================================
``runner``         running ``python -m rig.cli ...`` with a time limit; :class:`~.runner.Case`; classification
``workspace``      the clean session and calibration, mutated copies, what a resumed session must be
``hostile``        YAML bombs and tags, bytes that are not text, values no number field accepts
``procedures``     ``rig run PROCEDURE``: wrong types, ranges, hostile YAML, 10,000 and 10,001 steps
``rigfiles``       ``rig run --rig FILE``: axes, simulator error models, wrong-typed faults
``sessions``       ``rig solve/apply/evaluate/discover/replay/report`` on damaged sessions; scaled samples then
                   solved; ``samples_committed_bytes`` 0 then resumed; a damaged discover.json then reported
``calibrations``   ``rig apply/evaluate/export`` on damaged calibration files
``imports``        ``rig import`` of damaged recordings; a gyroscope file as accelerometer data
``options``        command-line options
``outputs``        output paths: a FIFO nobody reads, a device node (root only), a symbolic link, an own input
``names``          step names and an output folder written as shell and TeX (``$(touch F)``, ``$\\frac{1$``)
``signals``        kill -9, SIGTERM, SIGINT, SIGHUP and 3 SIGINTs in 0.1 s mid-step, then ``--resume``
``concurrency``    two concurrent resumes; two runs into one ``--out`` in the same second
``campaign``       the options, the quick sample, the run; ``report``: the tally and the failures
=================  ==========================================================================================

Part 1, bad inputs. A table of mutators x targets (procedures for `rig run`, rig files for `--rig`, corrupted
copies of a real session for `rig solve/apply/evaluate/discover/replay`, mutated calibration files for
`rig apply/evaluate`, recordings for `rig import`, command-line options, output paths, injected names), plus
seeded random cell mutations of samples.csv. Each input runs as `python -m rig.cli ...` in a subprocess with a
timeout and is classified:

- correct: the documented exit code (2 for bad input; 0 for valid-but-odd inputs such as a BOM or CRLF
  line endings, whose calibration must then equal the clean one), and for a refusal exactly one stderr line,
  naming the input, without "Traceback" or "internal error";
- traceback: "Traceback" or "internal error" on stderr;
- silent wrong result: exit 0 for an input that must be refused (or a valid input whose numbers differ from
  the clean run's, a YAML tag or a name that ran code, an output that replaced a FIFO, a link or an input);
- wrong exit code: anything else (1 for bad input, 2 for a valid input);
- bad message: the right exit code, but not one line, or a line that does not name the input;
- timeout: no answer within the timeout (a hang or a bomb);
- not tried: the attack could not be made (a device node by a user who is not root; a case whose session
  another case failed to record); never counted as handled.

A torn last line of samples.csv (no newline) is what a crash leaves, and a crash tears only the step in
progress: inside a *finished* step it means rows lost, and one line with exit 2 is the correct answer; in the
step in progress (an aborted session) the line is dropped with a warning and the rest solves.

Part 2, process faults. kill -9, SIGTERM, SIGINT, SIGHUP (and three SIGINTs within 0.1 s) sent to
`rig run procedures/six_position.yaml --time-scale 4` in the middle of a seeded step, once the session exists
and that step runs (a run that ended first is "not tried"), then `rig run --resume DIR`: every step recorded
exactly once (rows per step = the manifest's n_samples, t_s increasing within a step, each step's rows
contiguous), every step committed before the signal unchanged after the resume (else: data lost), the session
complete and its calibration within 5 sigma of an uninterrupted run of the same simulated sensor. Concurrent
resumes: two `rig run --resume DIR` at once on one interrupted session: exactly one proceeds, the other exits 1
with one line naming the holder's pid, and the session is intact. Two runs into one --out at once: distinct ids.

Prints the tally and every failure (input, command, exit code, first stderr line). Steps in the report are
counted from 1, as rig's messages count them (index N-1 in samples.csv).
"""
