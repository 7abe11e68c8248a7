// A job's verdict in the dashboard's words: the counts by verdict and the coverage line, the same
// figures cmmctl and the report print (docs/result.md, Inspection).

// {pass, fail, undecided, not_measured, excluded} as one line.
export function counts_text(c, separator = ', ') {
  if (!c) return '–';
  return [`${c.pass} pass`, `${c.fail} fail`, `${c.undecided} undecided`, `${c.not_measured} not measured`,
          `${c.excluded || 0} excluded`].join(separator);
}

// The record's verdict ({verdict, coverage, edge_points, holes}), or one made from a result's inspection.
export function verdict_of(record, inspection) {
  if (record && record.verdict) return record.verdict;
  if (!inspection) return null;
  return {verdict: inspection.verdict, coverage: inspection.coverage, edge_points: inspection.counts.edge_points,
          holes: inspection.counts.holes};
}
