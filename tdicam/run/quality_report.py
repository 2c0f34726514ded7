"""The words and tables of the imaging questions (:mod:`tdicam.run.quality`) in the summary
``tdicam run`` prints and in report.md: SNR on a flat region of the target and its gain over
one read, PSNR and SSIM against the ideal target, pixels at full scale and the warning line
of a saturated stage. They read only the report's measurement rows, so a stored report can
be re-rendered.
"""

from __future__ import annotations

from tdicam.run.quality import SATURATED_PERCENT

__all__ = ["summary_lines", "markdown_lines", "saturation_warnings"]


def _v(v, f):
    return "-" if v is None else format(v, f)


def saturation_warnings(rows):
    """One ``WARNING:`` line per sweep point with a stage more than
    :data:`~tdicam.run.quality.SATURATED_PERCENT` per cent at full scale."""
    out = []
    for r in rows:
        c = r.get("clipping")
        if not c or not c["saturated"]:
            continue
        parts = [f"{c[k]['at_full_scale_percent']:.1f} % of {_NAME[k]} pixels at full scale "
                 f"({c[k]['full_scale_dn']} DN)" for k in c["saturated"]]
        out.append(f"WARNING: m={r['stages']}: saturated: {', '.join(parts)}; the images are "
                   f"clipped and their SNR and MTF measure the clipping (lower "
                   f"[target].signal_e or the gain)")
    return out


_NAME = {"raw": "raw-exposure", "output": "output"}


def summary_lines(rows):
    """The summary lines of every sweep point: region SNR and gain, PSNR / SSIM, full scale;
    then the warnings."""
    lines = []
    for r in rows:
        m = r["stages"]
        s = r.get("region_snr")
        if s is not None:
            if s["output_db"] is None:
                lines.append(f"  m={m}: SNR -: {s['note']}")
            else:
                lines.append(f"  m={m}: SNR {s['output_db']:.2f} dB, one read "
                             f"{_v(s['single_db'], '.2f')} dB, gain {_v(s['gain_db'], '.2f')} dB "
                             f"({s['region']}, {s['pixels']} px)")
        f = r.get("vs_target")
        if f is not None:
            o, one = f["output"], f["single"]
            lines.append(f"  m={m}: vs the ideal target: PSNR {_v(o['psnr_db'], '.2f')} dB, "
                         f"SSIM {_v(o['ssim'], '.3f')} (one read {_v(one['psnr_db'], '.2f')} "
                         f"dB, {_v(one['ssim'], '.3f')})")
        c = r.get("clipping")
        if c is not None:
            lines.append(f"  m={m}: at full scale: raw {c['raw']['at_full_scale_percent']:.1f} % "
                         f"({c['raw']['full_scale_dn']} DN), output "
                         f"{c['output']['at_full_scale_percent']:.1f} % "
                         f"({c['output']['full_scale_dn']} DN)")
    return lines + saturation_warnings(rows)


def _pct_fs(c):
    return f"{c['at_full_scale_percent']:.2f} ({c['full_scale_dn']} DN)"


def _table(title, header, rows):
    """A report.md section: ``## title``, the table of ``header`` cells and ``rows`` of
    cells."""
    return ([f"## {title}", "", "| " + " | ".join(header) + " |",
             "|" + "---|" * len(header)]
            + ["| " + " | ".join(map(str, r)) + " |" for r in rows])


def markdown_lines(rows):
    """report.md's sections of the imaging questions."""
    md = []
    snr = [r for r in rows if r.get("region_snr") is not None]
    if snr:
        md += _table("SNR on a flat region of the target",
                     ("stages", "region", "pixels", "SNR out (dB)", "SNR one read (dB)",
                      "gain (dB)"),
                     [(r["stages"], s["region"], s["pixels"], _v(s["output_db"], ".2f"),
                       _v(s["single_db"], ".2f"), _v(s["gain_db"], ".2f"))
                      for r in snr for s in [r["region_snr"]]])
        md += [""] + [f"* m = {r['stages']}: {r['region_snr']['note']}" for r in snr
                      if r["region_snr"].get("note")]
        md += ["", "SNR = 20 log10(signal / noise) on the pixels the ideal target makes flat "
               "(3 x 3 neighbourhood within 1 % of its range): signal = the mean above the "
               "zero-light pedestal times the light's share S / (S + dark); noise = the RMS "
               "deviation of those pixels about a least-squares gain-and-offset fit to the "
               "target (the target's own variation there is not noise). One read: the single "
               "exposure that enters TDI; gain = output minus one read.", ""]
    fid = [r for r in rows if r.get("vs_target") is not None]
    if fid:
        md += _table("PSNR and SSIM against the ideal target",
                     ("stages", "PSNR out (dB)", "SSIM out", "PSNR one read (dB)",
                      "SSIM one read"),
                     [(r["stages"], _v(f["output"]["psnr_db"], ".2f"),
                       _v(f["output"]["ssim"], ".3f"), _v(f["single"]["psnr_db"], ".2f"),
                       _v(f["single"]["ssim"], ".3f")) for r in fid for f in [r["vs_target"]]])
        md += ["", f"Measured {fid[0]['vs_target']['method']}.", ""]
    clip = [r for r in rows if r.get("clipping") is not None]
    if clip:
        md += _table("Saturation and clipping",
                     ("stages", "raw at full scale (%)", "raw at 0 (%)",
                      "output at full scale (%)", "output at 0 (%)"),
                     [(r["stages"], _pct_fs(c["raw"]), f"{c['raw']['at_zero_percent']:.2f}",
                       _pct_fs(c["output"]), f"{c['output']['at_zero_percent']:.2f}")
                      for r in clip for c in [r["clipping"]]])
        md += [""] + [f"* **{w}**" for w in saturation_warnings(clip)]
        md += ["", f"A stage with more than {SATURATED_PERCENT:g} % of its pixels at full scale "
               "is saturated: its images are clipped.", ""]
    return md
