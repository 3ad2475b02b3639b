//! SPI1 with DMA1 channels 1 and 2: the BiSS-C encoder's frame, clocked once per PWM period
//! without the CPU (the [`stm32g4_axis::biss::FrameTransfer`] implementation [`SpiFrames`]).
//! Built with the `biss-encoder` feature, in place of the incremental encoder on TIM2.
//!
//! | setting | value | RM0440 |
//! |---|---|---|
//! | SPI1 | master, 8-bit frames, CPOL = 1 (MA idles high), CPHA = 1 (SLO sampled on MA's rising edge), NSS by software | §39.5, §39.7.1 |
//! | MA clock | the fastest PCLK2 / 2^(BR+1) within [`MAX_MA_HZ`]: 5.31 MHz, a 64-bit frame in 12 µs | §39.7.1 |
//! | DMA | DMA1 channel 1 ← SPI1_RX (DMAMUX request 10), channel 2 → SPI1_TX (request 11), 8 bytes each, memory increment; TX sends 0xFF (MOSI is not connected: SPI only clocks) | §12.3.2 (DMAMUX request table), §11 |
//! | start | channels disabled, counters reloaded, RX channel, TX channel, then SPE: the order of §39.5.9 | |
//! | done | the RX channel's counter at 0 | |
//! | clocks | DMA1 and DMAMUX1 are clocked by `embassy_stm32::init`; their channel interrupts stay off (no TCIE) | |
//!
//! The control interrupt reads the frame started one period before and starts the next
//! ([`stm32g4_axis::biss::BissEncoder::position`]); a frame whose counter is not at 0 then is a
//! timeout (signal loss).

use core::ptr::{addr_of, read_volatile};
use core::sync::atomic::{compiler_fence, Ordering};

use embassy_stm32::gpio::{AfType, Flex, OutputType, Pull, Speed};
use embassy_stm32::pac::bdma::vals::{Dir, Size};
use embassy_stm32::pac::spi::vals::{Br, Cpha, Cpol, Ds, Frxth, Mstr};
use embassy_stm32::peripherals::{DMA1_CH1, DMA1_CH2, SPI1};
use embassy_stm32::spi::{MisoPin, SckPin};
use embassy_stm32::{pac, rcc, Peri};
use static_cell::StaticCell;
use stm32g4_axis::biss::FrameTransfer;
use stm32g4_settings::spi::BaudRate;

use crate::clocks::PCLK2_HZ;
use crate::pins::alternate;

/// The fastest MA clock: BiSS-C encoders take up to 10 MHz, but the line delay (cable and
/// transceivers, ≈ 10 ns/m) must stay below half a bit, as the SPI samples without delay
/// compensation: 5 MHz allows about 10 m of cable.
const MAX_MA_HZ: u32 = 5_500_000;
/// SPI1's baud rate (SPI1 is on APB2).
const BAUD: BaudRate = match BaudRate::at_most(PCLK2_HZ, MAX_MA_HZ) {
    Ok(b) => b,
    Err(_) => panic!("no SPI1 prescaler for the BiSS clock"),
};
/// Bytes clocked per frame: the 50 bits of a 36-bit position frame, the idle and ack bits of
/// the line delay, and room for the start of the timeout.
pub const FRAME_BYTES: usize = 8;
/// DMAMUX1 request of SPI1_RX and SPI1_TX (RM0440 Table 91; stm32-data for the G474).
const SPI1_RX_REQUEST: u8 = 10;
const SPI1_TX_REQUEST: u8 = 11;
/// DMA1 channel indices (0-based; DMAMUX1 channel n feeds DMA1 channel n + 1).
const RX_CHANNEL: usize = 0;
const TX_CHANNEL: usize = 1;
/// What MOSI sends (not connected: only the clock matters).
static TX_BYTES: [u8; FRAME_BYTES] = [0xFF; FRAME_BYTES];
/// The RX buffer the DMA writes.
static RX_STORAGE: StaticCell<[u8; FRAME_BYTES]> = StaticCell::new();

const _: () = {
    // 170 MHz / 32 = 5.3125 MHz: 64 bits in 12.0 µs, inside the 25 µs period.
    assert!(BAUD.sck_hz == 5_312_500);
    assert!((FRAME_BYTES as u64) * 8 * 1_000_000_000 / (BAUD.sck_hz as u64) < 25_000 / 2);
    // The reference servo's frame (16 + 20 position bits) fits with 14 bits of line delay.
    assert!(FRAME_BYTES * 8 >= 50 + 4);
};

/// The encoder's interface pins and DMA channels.
pub struct BissPins<MA: embassy_stm32::gpio::Pin, SLO: embassy_stm32::gpio::Pin> {
    /// SPI1.
    pub spi: Peri<'static, SPI1>,
    /// MA: SPI1_SCK to the RS-422 driver.
    pub ma: Peri<'static, MA>,
    /// SLO: SPI1_MISO from the RS-422 receiver.
    pub slo: Peri<'static, SLO>,
    /// DMA1 channel 1 (RX).
    pub rx_dma: Peri<'static, DMA1_CH1>,
    /// DMA1 channel 2 (TX).
    pub tx_dma: Peri<'static, DMA1_CH2>,
}

/// SPI1 and its two DMA channels, clocking one frame per [`FrameTransfer::start`].
pub struct SpiFrames {
    _pins: [Flex<'static>; 2],
    rx: *mut [u8; FRAME_BYTES],
    frame: [u8; FRAME_BYTES],
}

// SAFETY: `rx` points to a `'static` buffer only this driver (and the DMA it starts) uses; the
// driver lives in the control interrupt's context.
unsafe impl Send for SpiFrames {}

/// Configures SPI1 and DMA1 channels 1/2 (see the module table); no frame is started yet.
pub fn configure<MA: SckPin<SPI1>, SLO: MisoPin<SPI1>>(pins: BissPins<MA, SLO>) -> SpiFrames {
    rcc::enable_and_reset::<SPI1>();
    let spi = pac::SPI1;
    spi.cr1().write(|w| {
        w.set_mstr(Mstr::MASTER);
        w.set_cpol(Cpol::IDLE_HIGH);
        w.set_cpha(Cpha::SECOND_EDGE);
        w.set_br(Br::from_bits(BAUD.br));
        w.set_ssm(true);
        w.set_ssi(true);
    });
    spi.cr2().write(|w| {
        w.set_ds(Ds::BITS8);
        w.set_frxth(Frxth::QUARTER);
        w.set_rxdmaen(true);
    });
    let rx = RX_STORAGE.init([0; FRAME_BYTES]) as *mut [u8; FRAME_BYTES];
    let dr = spi.dr8().as_ptr() as u32;
    for (channel, request, dir, memory) in [
        (RX_CHANNEL, SPI1_RX_REQUEST, Dir::FROM_PERIPHERAL, rx as u32),
        (
            TX_CHANNEL,
            SPI1_TX_REQUEST,
            Dir::FROM_MEMORY,
            addr_of!(TX_BYTES) as u32,
        ),
    ] {
        pac::DMAMUX1
            .ccr(channel)
            .write(|w| w.set_dmareq_id(request));
        let ch = pac::DMA1.ch(channel);
        ch.cr().write(|w| {
            w.set_dir(dir);
            w.set_minc(true);
            w.set_psize(Size::BITS8);
            w.set_msize(Size::BITS8);
        });
        ch.par().write_value(dr);
        ch.mar().write_value(memory);
    }
    let (ma_af, slo_af) = (pins.ma.af_num(), pins.slo.af_num());
    let ma = alternate(
        pins.ma,
        ma_af,
        AfType::output(OutputType::PushPull, Speed::VeryHigh),
    );
    // The receiver's fail-safe output is high on an open line; the pull-up keeps it so
    // without a receiver: a missing encoder reads as no ack (signal loss).
    let slo = alternate(pins.slo, slo_af, AfType::input(Pull::Up));
    let _ = (pins.spi, pins.rx_dma, pins.tx_dma);
    SpiFrames {
        _pins: [ma, slo],
        rx,
        frame: [0; FRAME_BYTES],
    }
}

impl FrameTransfer for SpiFrames {
    fn take_frame(&mut self) -> Option<&[u8]> {
        if pac::DMA1.ch(RX_CHANNEL).ndtr().read().ndt() != 0 {
            return None;
        }
        // The DMA has written every byte: read them after its writes.
        compiler_fence(Ordering::Acquire);
        // SAFETY: `rx` is the driver's `'static` buffer, and the channel is done with it.
        self.frame = unsafe { read_volatile(self.rx) };
        Some(&self.frame)
    }

    fn start(&mut self) {
        let spi = pac::SPI1;
        // Stop whatever ran (a finished frame, or one that timed out), and drain the FIFO.
        spi.cr1().modify(|w| w.set_spe(false));
        spi.cr2().modify(|w| w.set_txdmaen(false));
        // `ch` with constant numbers: its `n < 8` assertion folds away, leaving no panic path
        // in the control interrupt (`panic-paths`).
        for ch in [pac::DMA1.ch(RX_CHANNEL), pac::DMA1.ch(TX_CHANNEL)] {
            ch.cr().modify(|w| w.set_en(false));
            ch.ndtr().write(|w| w.set_ndt(FRAME_BYTES as u16));
        }
        for _ in 0..FRAME_BYTES {
            if spi.sr().read().rxne() {
                let _ = spi.dr8().read();
            }
        }
        compiler_fence(Ordering::Release);
        pac::DMA1.ch(RX_CHANNEL).cr().modify(|w| w.set_en(true));
        pac::DMA1.ch(TX_CHANNEL).cr().modify(|w| w.set_en(true));
        spi.cr2().modify(|w| w.set_txdmaen(true));
        spi.cr1().modify(|w| w.set_spe(true));
    }
}
