//! Object dictionary (CiA 301 / ETG.1000.6): the data model od-gen generates ([`model`]), the
//! run-time store over the OD RAM ([`store`]), the access rules every path into it shares (SDO
//! abort codes [`abort`], value checks [`value`]), DOMAIN data outside the RAM ([`domain`]) and
//! the hook run after a committed download ([`hook`]), the object indices of the communication
//! area the stack serves ([`index`]) and the rule which entries are stored parameters
//! ([`storable`]).

pub mod abort;
pub mod dirty;
pub mod domain;
pub mod hook;
pub mod index;
pub mod model;
pub mod storable;
pub mod store;
pub mod value;

pub use abort::AbortCode;
pub use dirty::DirtyMap;
pub use domain::{DomainStore, NoDomains, RamDomain};
pub use hook::{DownloadHook, WithDomains};
pub use model::*;
pub use storable::{AutoStore, EntryRange, EntryTest, StorageGroup, StorageRules, WriteCondition};
pub use store::{Dictionary, StoreError};

/// A device description for unit tests: the standard mailbox layout (SM0 0x1000/256, SM1
/// 0x1100/256), process data at 0x1200/0x1600, free run only, CoE with PDO assign/config.
#[cfg(test)]
pub(crate) const fn test_device() -> DeviceInfo {
    const NONE: SmLayout = SmLayout {
        start: 0,
        length: 0,
        control: 0,
    };
    DeviceInfo {
        profile: "test",
        name: "",
        vendor_id: 0,
        product_code: 0,
        revision: 0,
        mailbox_out: SmLayout {
            start: 0x1000,
            length: 256,
            control: 0x26,
        },
        mailbox_in: SmLayout {
            start: 0x1100,
            length: 256,
            control: 0x22,
        },
        boot_mailbox_out: None,
        boot_mailbox_in: None,
        outputs: SmLayout {
            start: 0x1200,
            ..NONE
        },
        inputs: SmLayout {
            start: 0x1600,
            ..NONE
        },
        sync: SyncSupport {
            free_run: true,
            sm_synchronous: false,
            dc_sync0: false,
            dc_sync1: false,
            min_cycle_ns: 0,
            max_cycle_ns: 0,
            cycle_step_ns: 1,
            allowed_cycles_ns: &[],
            sync_flag_in_sync: false,
            free_run_min_cycle_ns: 0,
            free_run_max_cycle_ns: 0,
            input_shift_step_ns: 0,
            input_shift_reserve_ns: 0,
            input_shift_parameter: None,
            sync_error_at_limit: false,
            sync_error_on_missed_outputs: false,
            sm_event_missed_subindex: 0x0B,
        },
        max_pdo_entries: 8,
        max_pdo_bytes: 256,
        max_process_bytes: 256,
        mailbox_protocols: 0,
        coe: CoeDetails {
            sdo: true,
            sdo_info: false,
            pdo_assign: true,
            pdo_config: true,
            upload_at_startup: false,
            complete_access: false,
        },
        esm: EsmRules {
            op_requires_outputs: true,
            safeop_op_timeout_ms: 9000,
            op_exit_while_enabled_error: None,
            al_error_alarms: &[],
            link_loss_error: None,
            sync_error_al_code: 0x001A,
            sync_lock_timeout_ms: None,
            pdi_error: None,
            lost_outputs: None,
            al_error_leds: &[],
        },
        sdo_write_to_rx_mapped: RxMappedWrite::Allowed,
        station_alias_parameter: None,
        station_alias_selector: None,
        emcy: crate::od::EmcyRules::CIA301,
        settings: &[],
    }
}
