//! What runs when an SDO download has been committed to the OD: the application's hook (e.g. the
//! 1010h/1011h parameter store) and the board's store of DOMAIN data outside the OD RAM.

use super::abort::AbortCode;
use super::domain::DomainStore;
use super::model::Profile;
use super::store::Dictionary;

/// Application action on a committed SDO download, run before the download response is sent
/// (see `CoeServer::handle_with` in `crate::mailbox::coe`).
pub trait DownloadHook {
    /// `index:subindex` was just written with a value that passed every SDO check; `Err` turns
    /// the response into an SDO abort with that code (the hook restores the entry's value if
    /// the write must not stick).
    fn downloaded(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode>;

    /// A complete-access download to `index` from `first_subindex` on (ETG.1000.6 §5.6.2.1.1:
    /// 0 or 1) has been committed: every entry of the object from there was written. Default:
    /// [`Self::downloaded`] with `first_subindex`.
    fn downloaded_complete(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        first_subindex: u8,
    ) -> Result<(), AbortCode> {
        self.downloaded(od, index, first_subindex)
    }

    /// The board's store of DOMAIN data outside the OD RAM, if the hook carries one (see
    /// [`WithDomains`]); `None`: domains are refused as by [`NoDomains`](super::domain::NoDomains).
    fn domains(&mut self) -> Option<&mut dyn DomainStore> {
        None
    }

    /// Whether [`Self::downloaded`] (or [`Self::downloaded_complete`]) after a download to
    /// object `index` of `profile` reads or writes OD RAM outside that object's entries: the
    /// slave's mailbox side then loads the whole OD RAM for the request instead of the
    /// object's entries alone (`crate::slave::mailbox_side`). Default: yes, the answer that is
    /// always right.
    fn reaches_beyond_object(&self, profile: &Profile, index: u16) -> bool {
        let _ = (profile, index);
        true
    }
}

/// A download hook together with the board's domain store: what
/// `Slave::on_esc_event_full` passes down to the SDO server.
pub struct WithDomains<'a, H: ?Sized> {
    /// The hook run on committed downloads.
    pub hook: &'a mut H,
    /// The domain store.
    pub domains: &'a mut dyn DomainStore,
}

impl<H: DownloadHook + ?Sized> DownloadHook for WithDomains<'_, H> {
    fn downloaded(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<(), AbortCode> {
        self.hook.downloaded(od, index, subindex)
    }

    fn downloaded_complete(
        &mut self,
        od: &mut Dictionary<'_>,
        index: u16,
        first_subindex: u8,
    ) -> Result<(), AbortCode> {
        self.hook.downloaded_complete(od, index, first_subindex)
    }

    fn domains(&mut self) -> Option<&mut dyn DomainStore> {
        Some(&mut *self.domains)
    }

    fn reaches_beyond_object(&self, profile: &Profile, index: u16) -> bool {
        self.hook.reaches_beyond_object(profile, index)
    }
}

/// No action.
impl DownloadHook for () {
    fn downloaded(&mut self, _: &mut Dictionary<'_>, _: u16, _: u8) -> Result<(), AbortCode> {
        Ok(())
    }

    fn reaches_beyond_object(&self, _: &Profile, _: u16) -> bool {
        false
    }
}
