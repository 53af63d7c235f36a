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
}
