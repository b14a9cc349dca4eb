//! Simulated campaigns as the identifier sees records.

use nalgebra::DMatrix;

use crate::campaign::Campaign;

impl Campaign {
    /// The hits as an [`ident::Campaign`]: the force as the one input
    /// (`force`), the acceleration of every floor as outputs in floor order
    /// (`acc1`, `acc2`, ...), records labelled `hit 1`, `hit 2`, ...
    pub fn to_ident(&self) -> ident::Campaign {
        let records = self
            .hits
            .iter()
            .map(|h| {
                let n = h.force.len();
                let inputs = DMatrix::from_row_slice(1, n, &h.force);
                let outputs =
                    DMatrix::from_fn(h.accelerations.len(), n, |i, k| h.accelerations[i][k]);
                ident::Record::new(inputs, outputs)
            })
            .collect::<Vec<_>>();
        let floors = self.hits.first().map_or(0, |h| h.accelerations.len());
        ident::Campaign::named(
            records,
            self.dt_s,
            vec!["force".into()],
            (1..=floors).map(|i| format!("acc{i}")).collect(),
            (1..=self.hits.len()).map(|h| format!("hit {h}")).collect(),
        )
    }
}
