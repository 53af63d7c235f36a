//! Family dispatch: every parameter of a family, and lookup by user key, through the
//! family-independent [`ParamMeta`] view. No allocation.

use crate::param::{Family, ParamMeta};
use crate::{bonfiglioli, nord, sew};

/// A parameter of any family, as a trait object.
pub type AnyParam = &'static (dyn ParamMeta + Sync);

/// Iterator over the parameters of one family, in table order (see [`params`]).
#[derive(Debug, Clone)]
pub struct FamilyParams(Inner);

#[derive(Debug, Clone)]
enum Inner {
    Sew(core::slice::Iter<'static, sew::Param>),
    Nord(core::slice::Iter<'static, nord::Param>),
    Bonfiglioli(core::slice::Iter<'static, bonfiglioli::Param>),
}

impl Iterator for FamilyParams {
    type Item = AnyParam;

    fn next(&mut self) -> Option<AnyParam> {
        match &mut self.0 {
            Inner::Sew(it) => it.next().map(|p| p as AnyParam),
            Inner::Nord(it) => it.next().map(|p| p as AnyParam),
            Inner::Bonfiglioli(it) => it.next().map(|p| p as AnyParam),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        match &self.0 {
            Inner::Sew(it) => it.size_hint(),
            Inner::Nord(it) => it.size_hint(),
            Inner::Bonfiglioli(it) => it.size_hint(),
        }
    }
}

impl ExactSizeIterator for FamilyParams {}

/// Every parameter of `family`, in table order.
pub fn params(family: Family) -> FamilyParams {
    FamilyParams(match family {
        Family::Movidrive => Inner::Sew(sew::params().iter()),
        Family::Nord => Inner::Nord(nord::params().iter()),
        Family::Bonfiglioli => Inner::Bonfiglioli(bonfiglioli::params().iter()),
    })
}

/// Look up a parameter of `family` by the key users type: menu/parameter number (`P813`,
/// `813`, `P102`, `1376`) or bus index, as each family's `lookup` accepts it.
pub fn lookup(family: Family, key: &str) -> Option<AnyParam> {
    match family {
        Family::Movidrive => sew::lookup(key).map(|p| p as AnyParam),
        Family::Nord => nord::lookup(key).map(|p| p as AnyParam),
        Family::Bonfiglioli => bonfiglioli::lookup(key).map(|p| p as AnyParam),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_reaches_each_family_table() {
        assert_eq!(params(Family::Movidrive).len(), sew::params().len());
        assert_eq!(params(Family::Nord).count(), nord::params().len());
        assert_eq!(
            params(Family::Bonfiglioli).count(),
            bonfiglioli::params().len()
        );
        assert_eq!(
            lookup(Family::Movidrive, "P813").map(|p| p.bus_index()),
            Some(8600)
        );
        assert_eq!(
            lookup(Family::Nord, "P102").map(|p| p.bus_index()),
            Some(0x66)
        );
        assert_eq!(
            lookup(Family::Bonfiglioli, "1376").map(|p| p.bus_index()),
            Some(1376)
        );
        assert!(lookup(Family::Nord, "P9999").is_none());
    }

    #[test]
    fn labels_wire_ranges_and_value_lists_per_family() {
        let sew = |k| lookup(Family::Movidrive, k).unwrap();
        assert_eq!(sew("P813").label().as_str(), "P813");
        assert_eq!(sew("P080.1").label().as_str(), "P080.1");
        assert_eq!(
            lookup(Family::Nord, "P102").unwrap().label().as_str(),
            "P102"
        );
        let bonfi = |k| lookup(Family::Bonfiglioli, k).unwrap();
        assert_eq!(bonfi("1376").label().as_str(), "1376");
        let element = crate::nord::ParamElement {
            param: crate::nord::by_number(700).unwrap(),
            element: 2,
        };
        assert_eq!(ParamMeta::label(&element).as_str(), "P700[-02]");

        // SEW data are 32 bits, signed where the range goes below zero (P224 ±…), unsigned where
        // it does not (P130), either sign without a range.
        let p224 = sew("P224");
        assert!(p224.raw_range().unwrap().0 < 0);
        assert_eq!(
            p224.wire_range(),
            (i64::from(i32::MIN), i64::from(i32::MAX))
        );
        assert_eq!(sew("P130").wire_range(), (0, i64::from(u32::MAX)));
        // Bonfiglioli: the data type's width.
        assert_eq!(
            bonfi("210").wire_range(),
            (i64::from(i32::MIN), i64::from(i32::MAX))
        );
        assert_eq!(bonfi("218").wire_range(), (-32768, 32767));

        // A SEW value list without a printed range is the whole domain (P870); a list inside a
        // range is not (Bonfiglioli 412 names three of 0…44).
        assert!(sew("P870").value_list_exhaustive());
        assert!(!sew("P130").value_list_exhaustive());
        assert!(!bonfi("412").value_list_exhaustive());
    }
}
