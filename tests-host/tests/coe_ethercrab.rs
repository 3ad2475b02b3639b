//! ethercrab's SDO information calls against the simulated drive: the object quantities and the
//! object lists (ETG.1000.6 §5.6.3.3) match the standard profile's dictionary as od-gen
//! generates it.

use ethercrab::ObjectDescriptionListQuery;
use tests_host::{block_on, master};

/// Indices of the standard profile's objects that satisfy `pred`, in index order.
fn profile_indices(pred: impl Fn(&od_gen::Profile, &od_gen::model::Object) -> bool) -> Vec<u16> {
    let p = od_gen::builtin("standard").expect("standard profile");
    let mut v: Vec<u16> = p
        .objects
        .iter()
        .filter(|o| pred(&p, o))
        .map(|o| o.index)
        .collect();
    v.sort_unstable();
    v
}

/// ethercrab's SDO information futures hold two 128 KiB `heapless::Vec`s: run them on a thread
/// with a large stack.
fn with_big_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(f)
        .expect("thread")
        .join()
        .unwrap_or_else(|e| std::panic::resume_unwind(e));
}

#[test]
fn ethercrab_sdo_info_lists_match_the_profile() {
    with_big_stack(sdo_info_lists_match_the_profile);
}

fn sdo_info_lists_match_the_profile() {
    let all = profile_indices(|_, _| true);
    let rx = profile_indices(|_, o| o.entries.iter().any(|e| e.pdo.rx()));
    let tx = profile_indices(|_, o| o.entries.iter().any(|e| e.pdo.tx()));
    // List 4: what the parameter storage stores (od-gen's copy of params::is_storable, checked
    // against it at compile time); list 5: the profile's `setting = true` entries.
    let backup = profile_indices(|p, o| o.entries.iter().any(|e| p.is_backup(o, e)));
    let settings = profile_indices(|_, o| o.entries.iter().any(|e| e.setting));
    assert!(!backup.is_empty() && !settings.is_empty());
    assert!(
        all.contains(&0x2FF0),
        "the test domain is in the dictionary"
    );
    block_on(async {
        let (m, transport) = master();
        tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init");
        let sd = group.iter(md).next().expect("one drive");

        let counts = sd
            .sdo_info_object_quantities()
            .await
            .expect("object quantities")
            .expect("the drive has a CoE mailbox");
        assert_eq!(
            (
                usize::from(counts.all),
                usize::from(counts.rx_pdo_mappable),
                usize::from(counts.tx_pdo_mappable),
                usize::from(counts.stored_for_device_replacement),
                usize::from(counts.startup_parameters)
            ),
            (all.len(), rx.len(), tx.len(), backup.len(), settings.len())
        );

        for (query, expected) in [
            (ObjectDescriptionListQuery::All, &all),
            (ObjectDescriptionListQuery::RxPdoMappable, &rx),
            (ObjectDescriptionListQuery::TxPdoMappable, &tx),
            (
                ObjectDescriptionListQuery::StoredForDeviceReplacement,
                &backup,
            ),
            (ObjectDescriptionListQuery::StartupParameters, &settings),
        ] {
            let list = sd
                .sdo_info_object_description_list(query)
                .await
                .expect("object list")
                .expect("CoE mailbox");
            assert_eq!(list.as_slice(), expected.as_slice(), "{query}");
        }
        // Plain SDO keeps working after SDO information.
        let device_type = sd.sdo_read::<u32>(0x1000, 0).await.expect("1000h");
        assert_eq!(device_type, 0x0002_0192);
    });
}
