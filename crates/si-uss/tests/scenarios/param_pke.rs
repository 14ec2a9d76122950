//! A parameter address on the wire: the split of a parameter number into PNU and IND
//! (si_uss::param) encoded in a PKE word (si_uss::frame). Here rather than in param.rs's own
//! tests, so that param.rs does not import frame.rs, which imports it.

use si_uss::frame::Pke;
use si_uss::param::ParamAddress;

#[test]
fn p2029_index_5_is_pke_01d_and_ind_8005() {
    let (pnu, ind) = ParamAddress::new(2029, 5).unwrap().split().unwrap();
    assert_eq!(Pke::new(1, false, pnu).0, 0x101D);
    assert_eq!(ind, 0x8005);
}
